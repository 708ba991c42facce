// The page of export_html (html_viewer.cpp): HTML, CSS and the viewer's JavaScript, with the
// placeholders @@TITLE@@ (HTML-escaped text), @@THREE_JS@@, @@ORBIT_CONTROLS@@ (the inlined
// libjs-three files), @@REVISION@@ (three.js revision) and @@MAP_JSON@@ (the map, JSON with
// every '<' escaped, so that no "</script" can end the block early).
//
// Scripts run in this order: (1) the error reporter, before anything else, so that a failure
// of any later script is listed in the page; (2) three.js; (3) OrbitControls; (4) the map JSON
// (type application/json: data, not run); (5) the viewer, which draws the first frame
// synchronously and then marks <body data-vilma-state="drawn">.
#pragma once

namespace vilma::mapping::internal {

inline constexpr const char* kHtmlViewerPage = R"vilma(<!DOCTYPE html>
<html lang="en">
<head>
<meta charset="utf-8">
<meta name="viewport" content="width=device-width, initial-scale=1">
<meta name="generator" content="vilma export_html">
<title>@@TITLE@@</title>
<style>
html, body { margin: 0; height: 100%; overflow: hidden; background: #ffffff;
  font: 13px/1.35 sans-serif; color: #222; }
#view { position: absolute; inset: 0; width: 100%; height: 100%; display: block; }
.panel { position: absolute; background: rgba(255,255,255,0.88); border: 1px solid #bbb;
  border-radius: 4px; padding: 6px 9px; max-width: 46%; }
#info { left: 8px; top: 8px; }
#info h1 { font-size: 15px; margin: 0 0 4px 0; }
#info .swatch { display: inline-block; width: 18px; height: 4px; margin: 0 6px 3px 0;
  vertical-align: middle; }
#info label { display: block; white-space: nowrap; }
#info .toggles label { display: inline-block; margin-right: 10px; }
#details { left: 8px; bottom: 8px; font-family: monospace; white-space: pre; display: none; }
#help { right: 8px; bottom: 8px; color: #555; }
#vilma-errors { position: absolute; right: 8px; top: 8px; margin: 0; max-width: 46%;
  background: #fee; border: 1px solid #c33; color: #900; padding: 6px; white-space: pre-wrap;
  display: none; }
</style>
<script>
// (1) Error reporter: every error, unhandled rejection, console.error and console.warn is
// listed in the errors panel (#vilma-errors) and counted in the data-vilma-errors attribute
// of the html element.
(function () {
  var messages = [];
  function report(kind, text) {
    messages.push(kind + ': ' + text);
    document.documentElement.setAttribute('data-vilma-errors', String(messages.length));
    var show = function () {
      var el = document.getElementById('vilma-errors');
      if (!el) return false;
      el.textContent = messages.join('\n');
      el.style.display = 'block';
      return true;
    };
    if (!show()) document.addEventListener('DOMContentLoaded', show);
  }
  window.vilmaReport = report;
  window.addEventListener('error', function (e) {
    report('error', (e.message || 'script error') + ' (' + (e.filename || 'page') + ':' +
      (e.lineno || 0) + ')');
  });
  window.addEventListener('unhandledrejection', function (e) {
    report('error', 'unhandled rejection: ' + e.reason);
  });
  ['error', 'warn'].forEach(function (level) {
    var original = console[level];
    console[level] = function () {
      report(level === 'warn' ? 'warning' : 'error', Array.prototype.join.call(arguments, ' '));
      original.apply(console, arguments);
    };
  });
  document.documentElement.setAttribute('data-vilma-errors', '0');
})();
</script>
<script>
// (2) three.js r@@REVISION@@ (MIT), inlined from Debian's libjs-three.
@@THREE_JS@@
</script>
<script>
// (3) OrbitControls (MIT), inlined from Debian's libjs-three.
@@ORBIT_CONTROLS@@
</script>
<script type="application/json" id="vilma-map-data">
@@MAP_JSON@@
</script>
</head>
<body data-vilma-state="loading">
<canvas id="view"></canvas>
<div id="info" class="panel"><h1 id="title"></h1><div id="counts"></div>
<div id="missions"></div><div class="toggles" id="toggles"></div></div>
<div id="details" class="panel"></div>
<div id="help" class="panel">drag: orbit &middot; wheel: zoom &middot; right or shift drag: pan
&middot; click a vertex: details and camera frustums &middot; h: hide panels</div>
<pre id="vilma-errors"></pre>
<script>
// (5) The viewer.
(function () {
  'use strict';
  var data = JSON.parse(document.getElementById('vilma-map-data').textContent);
  var origin = data.origin_m;  // subtracted from every position: float32 keeps mm precision
  var canvas = document.getElementById('view');
  var renderer;
  try {
    renderer = new THREE.WebGLRenderer({ canvas: canvas, antialias: true });
  } catch (e) {
    window.vilmaReport('error', 'WebGL is not available in this browser: ' + e.message);
    document.body.setAttribute('data-vilma-state', 'no-webgl');
    return;
  }
  renderer.setPixelRatio(window.devicePixelRatio || 1);
  renderer.setClearColor(0xffffff, 1);
  var scene = new THREE.Scene();

  function local(p_mm, i) {  // position i of a millimetre array, in the scene frame [m]
    return new THREE.Vector3(p_mm[3 * i] / 1000 - origin[0], p_mm[3 * i + 1] / 1000 - origin[1],
                             p_mm[3 * i + 2] / 1000 - origin[2]);
  }
  function positions(p_mm) {
    var out = new Float32Array(p_mm.length);
    for (var i = 0; i < p_mm.length; i += 3) {
      out[i] = p_mm[i] / 1000 - origin[0];
      out[i + 1] = p_mm[i + 1] / 1000 - origin[1];
      out[i + 2] = p_mm[i + 2] / 1000 - origin[2];
    }
    return out;
  }
  function geometry(array) {
    var g = new THREE.BufferGeometry();
    g.setAttribute('position', new THREE.BufferAttribute(array, 3));
    return g;
  }

  // Extent of the trajectories (the view is framed on them).
  var box = new THREE.Box3();
  data.missions.forEach(function (m) {
    for (var i = 0; i < m.vertex_ids.length; ++i) box.expandByPoint(local(m.p_mm, i));
  });
  var centre = box.getCenter(new THREE.Vector3());
  var size = Math.max(1, box.getSize(new THREE.Vector3()).length());

  var layers = { trajectories: [], vertices: [], landmarks: [], loops: [], axes: [], grid: [] };
  data.missions.forEach(function (m, mi) {
    var color = new THREE.Color(m.color);
    var p = positions(m.p_mm);
    var line = new THREE.Line(geometry(p), new THREE.LineBasicMaterial({ color: color }));
    var dots = new THREE.Points(geometry(p), new THREE.PointsMaterial(
      { color: color, size: 5, sizeAttenuation: false }));
    // IMU axes of every vertex (x red, y green, z blue), hidden until asked for.
    var axisLength = 0.02 * size;
    var axisObjects = [0xd62728, 0x2ca02c, 0x1f4fd6].map(function (axisColor, axis) {
      var seg = new Float32Array(m.vertex_ids.length * 6);
      for (var i = 0; i < m.vertex_ids.length; ++i) {
        var a = local(m.p_mm, i);
        var q = new THREE.Quaternion(m.q_G_I[4 * i + 1], m.q_G_I[4 * i + 2], m.q_G_I[4 * i + 3],
                                     m.q_G_I[4 * i]);
        var d = new THREE.Vector3(axis === 0 ? 1 : 0, axis === 1 ? 1 : 0, axis === 2 ? 1 : 0)
          .applyQuaternion(q).multiplyScalar(axisLength).add(a);
        seg.set([a.x, a.y, a.z, d.x, d.y, d.z], 6 * i);
      }
      var o = new THREE.LineSegments(geometry(seg), new THREE.LineBasicMaterial({ color: axisColor }));
      o.visible = false;
      return o;
    });
    [line, dots].concat(axisObjects).forEach(function (o) {
      o.userData.mission = mi;
      scene.add(o);
    });
    layers.trajectories.push(line);
    layers.vertices.push(dots);
    layers.axes = layers.axes.concat(axisObjects);
  });

  var L = data.landmarks;
  var qualityColor = { 2: 0x8c8c8c, 0: 0x8a9bd6, 1: 0xeb9f9f };
  [1, 0, 2].forEach(function (quality) {
    var p = [];
    for (var i = 0; i < L.quality.length; ++i) {
      if (L.quality[i] === quality) p.push(L.p_mm[3 * i], L.p_mm[3 * i + 1], L.p_mm[3 * i + 2]);
    }
    if (p.length === 0) return;
    var o = new THREE.Points(geometry(positions(p)), new THREE.PointsMaterial(
      { color: qualityColor[quality], size: 2, sizeAttenuation: false }));
    scene.add(o);
    layers.landmarks.push(o);
  });

  if (data.loop_closures.length > 0) {
    var seg = new Float32Array(data.loop_closures.length * 6);
    data.loop_closures.forEach(function (c, k) {
      var a = local(data.missions[c[0]].p_mm, c[1]), b = local(data.missions[c[2]].p_mm, c[3]);
      seg.set([a.x, a.y, a.z, b.x, b.y, b.z], 6 * k);
    });
    var loops = new THREE.LineSegments(geometry(seg),
      new THREE.LineBasicMaterial({ color: new THREE.Color(data.loop_closure_color) }));
    scene.add(loops);
    layers.loops.push(loops);
  }

  // Ground grid in the x-y plane under the trajectories, 1/2/5 x 10^k metre cells.
  var step = Math.pow(10, Math.floor(Math.log10(size / 10)));
  if (size / step > 50) step *= 5; else if (size / step > 20) step *= 2;
  var cells = 2 * Math.ceil(0.75 * size / step);
  var grid = new THREE.GridHelper(cells * step, cells, 0xc8c8c8, 0xe6e6e6);
  grid.rotation.x = Math.PI / 2;
  grid.position.set(Math.round(centre.x / step) * step, Math.round(centre.y / step) * step,
                    box.min.z);
  scene.add(grid);
  var frameG = new THREE.AxesHelper(Math.max(step, 0.05 * size));
  frameG.position.set(-origin[0], -origin[1], -origin[2]);
  scene.add(frameG);
  layers.grid.push(grid, frameG);

  // The selected vertex: a marker, its IMU axes and the frustums of the mission's cameras.
  var selection = new THREE.Group();
  scene.add(selection);

  var camera = new THREE.PerspectiveCamera(50, 1, size * 1e-4, size * 100);
  camera.up.set(0, 0, 1);
  camera.position.copy(centre).add(new THREE.Vector3(-0.45, -0.75, 0.6).multiplyScalar(size));
  var controls = new THREE.OrbitControls(camera, canvas);
  controls.target.copy(centre);
  controls.update();

  var pending = false;
  function render() {
    pending = false;
    renderer.render(scene, camera);
  }
  function requestRender() {
    if (!pending) {
      pending = true;
      window.requestAnimationFrame(render);
    }
  }
  function resize() {
    var w = window.innerWidth, h = window.innerHeight;
    renderer.setSize(w, h, false);
    camera.aspect = w / Math.max(1, h);
    camera.updateProjectionMatrix();
  }
  controls.addEventListener('change', requestRender);
  window.addEventListener('resize', function () { resize(); requestRender(); });

  // ---- panels ----
  function text(tag, content, parent) {
    var el = document.createElement(tag);
    el.textContent = content;
    if (parent) parent.appendChild(el);
    return el;
  }
  document.getElementById('title').textContent = data.title;
  var nVertices = data.missions.reduce(function (n, m) { return n + m.vertex_ids.length; }, 0);
  document.getElementById('counts').textContent = data.missions.length + ' mission(s), ' +
    nVertices + ' vertices, ' + L.embedded + ' of ' + L.total + ' landmarks (' + L.qualities +
    '), ' + data.loop_closures.length + ' loop closure(s); frame G; three.js r' + THREE.REVISION;
  // "name (id8)", or "mission id8" for a mission without a name.
  function missionLabel(m) {
    var id = m.id.substring(0, 8);
    return m.name ? m.name + ' (' + id + ')' : 'mission ' + id;
  }
  // Visibility: an object shows when its layer is on and, for per-mission objects, its
  // mission is on.
  var layerShown = { trajectories: true, vertices: true, landmarks: true, loops: true,
                     axes: false, grid: true };
  var missionShown = data.missions.map(function () { return true; });
  function updateVisibility() {
    Object.keys(layers).forEach(function (name) {
      layers[name].forEach(function (o) {
        var mi = o.userData.mission;
        o.visible = layerShown[name] && (mi === undefined || missionShown[mi]);
      });
    });
    requestRender();
  }
  function checkbox(id, checked, label, onChange) {
    var el = document.createElement('label');
    var input = document.createElement('input');
    input.type = 'checkbox';
    input.id = id;
    input.checked = checked;
    input.addEventListener('change', function () { onChange(input.checked); });
    el.appendChild(input);
    el.appendChild(label);
    return el;
  }
  var missionsDiv = document.getElementById('missions');
  data.missions.forEach(function (m, mi) {
    var label = document.createElement('span');
    var swatch = text('span', '', label);
    swatch.className = 'swatch';
    swatch.style.background = m.color;
    label.appendChild(document.createTextNode(missionLabel(m) + ': ' +
      m.vertex_ids.length + ' vertices, ' + m.path_length_m.toFixed(1) + ' m' +
      (m.baseframe_known ? '' : ', baseframe unknown')));
    missionsDiv.appendChild(checkbox('mission-' + mi, true, label, function (on) {
      missionShown[mi] = on;
      updateVisibility();
    }));
  });
  var toggles = document.getElementById('toggles');
  Object.keys(layerShown).forEach(function (name) {
    toggles.appendChild(checkbox('toggle-' + name, layerShown[name],
      document.createTextNode(name === 'loops' ? 'loop closures' : name), function (on) {
        layerShown[name] = on;
        updateVisibility();
      }));
  });

  // ---- picking and details ----
  var raycaster = new THREE.Raycaster();
  function vertexAt(mi, i) {
    var m = data.missions[mi];
    var q = new THREE.Quaternion(m.q_G_I[4 * i + 1], m.q_G_I[4 * i + 2], m.q_G_I[4 * i + 3],
                                 m.q_G_I[4 * i]);
    return { mission: m, index: i, p: local(m.p_mm, i), q: q };
  }
  function fixed(v, n) { return (v >= 0 ? ' ' : '') + v.toFixed(n); }
  function select(mi, i) {
    var v = vertexAt(mi, i), m = v.mission;
    while (selection.children.length) selection.remove(selection.children[0]);
    var depth = Math.max(0.05, Math.min(2.0, 0.05 * size));
    var seg = [];
    m.cameras.forEach(function (c) {
      var q_I_C = new THREE.Quaternion(c.q_I_C[1], c.q_I_C[2], c.q_I_C[3], c.q_I_C[0]);
      var p_I_C = new THREE.Vector3(c.p_I_C_mm[0] / 1000, c.p_I_C_mm[1] / 1000, c.p_I_C_mm[2] / 1000);
      var apex = p_I_C.clone().applyQuaternion(v.q).add(v.p);
      var corners = [0, 1, 2, 3].map(function (k) {
        return new THREE.Vector3(c.corners[2 * k] * depth, c.corners[2 * k + 1] * depth, depth)
          .applyQuaternion(q_I_C).add(p_I_C).applyQuaternion(v.q).add(v.p);
      });
      corners.forEach(function (corner, k) {
        var next = corners[(k + 1) % 4];
        seg.push(apex.x, apex.y, apex.z, corner.x, corner.y, corner.z,
                 corner.x, corner.y, corner.z, next.x, next.y, next.z);
      });
    });
    if (seg.length) {
      selection.add(new THREE.LineSegments(geometry(new Float32Array(seg)),
        new THREE.LineBasicMaterial({ color: 0x111111 })));
    }
    var axes = new THREE.AxesHelper(depth);
    axes.position.copy(v.p);
    axes.quaternion.copy(v.q);
    selection.add(axes);
    selection.add(new THREE.Points(geometry(new Float32Array([v.p.x, v.p.y, v.p.z])),
      new THREE.PointsMaterial({ color: 0x000000, size: 11, sizeAttenuation: false })));
    var t = (BigInt(m.t0_ns) + BigInt(m.dt_ns[i])).toString();
    var euler = new THREE.Euler().setFromQuaternion(v.q, 'ZYX');
    var deg = 180 / Math.PI;
    var p_G = [v.p.x + origin[0], v.p.y + origin[1], v.p.z + origin[2]];
    var details = document.getElementById('details');
    details.textContent =
      'mission ' + (m.name ? m.name + ' (' + m.id + ')' : m.id) + '\n' +
      'vertex  ' + m.vertex_ids[i] + '  (' + (i + 1) + ' of ' + m.vertex_ids.length + ')\n' +
      't_ns    ' + t + '  (+' + (m.dt_ns[i] / 1e9).toFixed(3) + ' s in the mission)\n' +
      'p_G_I   [m]   ' + p_G.map(function (x) { return fixed(x, 3); }).join(' ') + '\n' +
      'q_G_I   w x y z ' + [m.q_G_I[4 * i], m.q_G_I[4 * i + 1], m.q_G_I[4 * i + 2],
                            m.q_G_I[4 * i + 3]].map(function (x) { return fixed(x, 4); }).join(' ') +
      '\n' + 'yaw pitch roll [deg] ' + [euler.z, euler.y, euler.x].map(function (x) {
        return fixed(x * deg, 1); }).join(' ') + '\n' +
      m.cameras.length + ' camera frustum(s) drawn, ' + depth.toFixed(2) + ' m deep';
    details.style.display = panelsShown ? 'block' : 'none';
    details.setAttribute('data-vertex', m.vertex_ids[i]);
    requestRender();
  }
  // The vertex under a point of the canvas (client pixels): among the dots within 8 px of
  // the ray, the one closest to the ray (the one `prefer` names, if it is among them).
  function pickAt(x, y, prefer) {
    var rect = canvas.getBoundingClientRect();
    var ndc = new THREE.Vector2((x - rect.left) / rect.width * 2 - 1,
                                -(y - rect.top) / rect.height * 2 + 1);
    raycaster.setFromCamera(ndc, camera);
    var distance = camera.position.distanceTo(controls.target);
    raycaster.params.Points.threshold =
      8 * 2 * distance * Math.tan(camera.fov * Math.PI / 360) / Math.max(1, rect.height);
    var targets = layers.vertices.filter(function (o) { return o.visible; });
    var hits = raycaster.intersectObjects(targets, false);
    if (hits.length === 0) return false;
    var best = hits[0];
    hits.forEach(function (h) {
      if (h.distanceToRay < best.distanceToRay) best = h;
    });
    hits.forEach(function (h) {
      if (prefer && data.missions[h.object.userData.mission].vertex_ids[h.index] === prefer) best = h;
    });
    select(best.object.userData.mission, best.index);
    return true;
  }
  var down = null;
  canvas.addEventListener('pointerdown', function (e) { down = [e.clientX, e.clientY]; });
  canvas.addEventListener('click', function (e) {
    if (down && Math.abs(e.clientX - down[0]) + Math.abs(e.clientY - down[1]) < 5) {
      pickAt(e.clientX, e.clientY, null);
    }
  });

  // The URL fragment: #vertex=<id> centres the view on the vertex and picks it at the centre
  // of the canvas (as a click there would); panels=0 hides the panels (key h toggles them).
  function applyHash() {
    var params = {};
    window.location.hash.replace(/^#/, '').split('&').forEach(function (kv) {
      var at = kv.indexOf('=');
      if (at > 0) params[kv.substring(0, at)] = decodeURIComponent(kv.substring(at + 1));
    });
    showPanels(params.panels !== '0');
    if (params.vertex === undefined) return;
    var id = params.vertex.toLowerCase();
    for (var mi = 0; mi < data.missions.length; ++mi) {
      var i = data.missions[mi].vertex_ids.indexOf(id);
      if (i < 0) continue;
      var p = local(data.missions[mi].p_mm, i);
      camera.position.add(p.clone().sub(controls.target));
      controls.target.copy(p);
      controls.update();
      var rect = canvas.getBoundingClientRect();
      if (!pickAt(rect.left + rect.width / 2, rect.top + rect.height / 2, id)) {
        window.vilmaReport('warning', 'vertex ' + id + ' is hidden or not pickable');
      }
      return;
    }
    window.vilmaReport('warning', 'vertex ' + id + ' is not in this map');
  }
  var panelsShown = true;
  function showPanels(on) {
    panelsShown = on;
    ['info', 'help'].forEach(function (id) {
      document.getElementById(id).style.display = on ? '' : 'none';
    });
    var details = document.getElementById('details');
    if (!on) details.style.display = 'none';
    else if (details.textContent) details.style.display = 'block';
  }
  window.addEventListener('keydown', function (e) {
    if (e.key === 'h') showPanels(!panelsShown);
  });
  window.addEventListener('hashchange', function () { applyHash(); render(); });

  resize();
  applyHash();
  render();
  var gl = renderer.getContext();
  var glError = gl.getError();
  if (glError !== gl.NO_ERROR) window.vilmaReport('error', 'WebGL error ' + glError);
  document.body.setAttribute('data-vilma-state', 'drawn');
  window.vilmaViewer = { scene: scene, camera: camera, controls: controls, pickAt: pickAt,
                         select: select, render: render };
})();
</script>
</body>
</html>
)vilma";

}  // namespace vilma::mapping::internal
