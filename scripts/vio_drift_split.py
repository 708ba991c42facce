#!/usr/bin/env python3
"""Split a VIO run's position error into what a yaw error explains and what a velocity error
does, and compare the estimated biases and velocity with the simulator's ground truth.

Why: an ATE says how far the trajectory drifted, not whether the cause is yaw (gyro bias),
scale / speed, or a sideways velocity error; each asks for a different fix.

Inputs: the ground truth (ASL state_groundtruth_estimate0/data.csv: p, q_wxyz, v, b_w, b_a),
the estimate (TUM, `vilma vio --out`) and its state log (`vilma vio --log-state`).
Model (posyaw alignment fitted to all poses, as `vilma eval --align posyaw`): with the attitude
error phi (global) and the body-frame velocity error dv_B,
    d e / dt = phi_z (z x v_gt) + R_gt dv_B   (+ roll/pitch terms, small here)
the yaw part Y(t) = int phi_z (z x v_gt) dt and the rest V = e - Y; V's increments are split
into along-track (along v_gt: speed, scale) and cross-track parts. Each part is reported as
the ATE of (ground truth + part), re-aligned, so the parts compare with the run's ATE (they
need not add up: parts can cancel).

Usage: vio_drift_split.py GT_CSV EST_TUM STATE_CSV   (needs numpy: /usr/bin/python3 on Debian)
Exit codes: 0 ok, 1 bad input, 2 usage.
"""
import sys

try:
    import numpy as np
except ImportError:
    sys.exit("vio_drift_split.py: needs numpy (Debian: /usr/bin/python3, python3-numpy)")


def q2r(w, x, y, z):
    n = np.sqrt(w * w + x * x + y * y + z * z)
    w, x, y, z = w / n, x / n, y / n, z / n
    return np.array([[1 - 2 * (y * y + z * z), 2 * (x * y - w * z), 2 * (x * z + w * y)],
                     [2 * (x * y + w * z), 1 - 2 * (x * x + z * z), 2 * (y * z - w * x)],
                     [2 * (x * z - w * y), 2 * (y * z + w * x), 1 - 2 * (x * x + y * y)]])


def fit_posyaw(g, p):
    """Aligned p (yaw about z + translation onto g) and the yaw rotation."""
    a, b = g - g.mean(0), p - p.mean(0)
    h = b[:, :2].T @ a[:, :2]
    yaw = np.arctan2(h[0, 1] - h[1, 0], h[0, 0] + h[1, 1])
    c, s = np.cos(yaw), np.sin(yaw)
    rz = np.array([[c, -s, 0], [s, c, 0], [0, 0, 1]])
    return (rz @ b.T).T + g.mean(0), rz


def ate(g, p):
    aligned, _ = fit_posyaw(g, p)
    return np.sqrt(((aligned - g) ** 2).sum(1).mean())


def rms(x):
    return np.sqrt((x ** 2).mean(0))


def main(argv):
    if len(argv) != 4:
        print(__doc__, file=sys.stderr)
        return 2
    try:
        gt = np.loadtxt(argv[1], delimiter=",", comments="#")
        est = np.loadtxt(argv[2], comments="#")
        st = np.loadtxt(argv[3], delimiter=",", skiprows=1)
    except (OSError, ValueError) as e:
        print(f"vio_drift_split.py: {e}", file=sys.stderr)
        return 1
    if gt.ndim != 2 or gt.shape[1] < 17 or est.ndim != 2 or st.ndim != 2 or st.shape[1] < 17:
        print("vio_drift_split.py: expected an ASL ground truth with v, b_w, b_a (17 columns), "
              "a TUM file and a --log-state CSV", file=sys.stderr)
        return 1
    tg, te, ts = gt[:, 0] * 1e-9, est[:, 0], st[:, 0] * 1e-9
    gi = np.clip(np.searchsorted(tg, te - 1e-6), 0, len(tg) - 1)
    si = np.clip(np.searchsorted(ts, te - 1e-6), 0, len(ts) - 1)
    ok = (np.abs(tg[gi] - te) < 0.003) & (np.abs(ts[si] - te) < 0.003)
    if ok.sum() < 10:
        print("vio_drift_split.py: fewer than 10 poses matched in time", file=sys.stderr)
        return 1
    est, te, gi, si = est[ok], te[ok], gi[ok], si[ok]
    g, v_gt, bw_gt, ba_gt = gt[gi, 1:4], gt[gi, 8:11], gt[gi, 11:14], gt[gi, 14:17]
    r_gt = [q2r(*q) for q in gt[gi, 4:8]]
    r_est = [q2r(q[3], q[0], q[1], q[2]) for q in est[:, 4:8]]
    s = st[si]
    aligned, rz = fit_posyaw(g, est[:, 1:4])
    err = aligned - g
    phi_z = np.array([((rz @ re @ rg.T)[1, 0] - (rz @ re @ rg.T)[0, 1]) / 2
                      for re, rg in zip(r_est, r_gt)])
    dt = np.diff(te, prepend=te[0])
    yaw_part = np.cumsum(phi_z[:, None] * np.c_[-v_gt[:, 1], v_gt[:, 0], 0 * v_gt[:, 0]]
                         * dt[:, None], 0)
    rest = err - yaw_part
    d_rest = np.diff(rest, axis=0, prepend=rest[:1])
    u = v_gt / np.maximum(np.linalg.norm(v_gt, axis=1, keepdims=True), 1e-6)
    along = (d_rest * u).sum(1, keepdims=True) * u
    cross = d_rest - along
    print(f"ATE {ate(g, est[:, 1:4]):.4f} m: yaw part {ate(g, g + yaw_part):.4f}, rest "
          f"{ate(g, g + rest):.4f} (along-track {ate(g, g + np.cumsum(along, 0)):.4f}, "
          f"cross-track {ate(g, g + np.cumsum(cross, 0)):.4f}); vertical "
          f"{np.sqrt((err[:, 2] ** 2).mean()):.4f}")
    print(f"yaw error rms {np.degrees(rms(phi_z)):.3f} deg, end {np.degrees(phi_z[-1]):+.3f}, "
          f"filter sigma at the end {np.degrees(s[-1, 16]):.3f}")
    fmt = lambda x, k: " ".join(f"{k * v:.3f}" for v in x)
    print(f"b_g error rms [mrad/s] {fmt(rms(s[:, 4:7] - bw_gt), 1e3)} (sigma at the end "
          f"{fmt(s[-1, 10:13], 1e3)})")
    print(f"b_a error rms [mm/s^2] {fmt(rms(s[:, 7:10] - ba_gt), 1e3)} (sigma at the end "
          f"{fmt(s[-1, 13:16], 1e3)})")
    # Body-frame velocity error (the estimate's M is yawed against the ground truth's W).
    dv = np.array([rg.T @ (rz @ ve - vg) for rg, ve, vg in zip(r_gt, s[:, 1:4], v_gt)])
    k = max(1, min(len(dv), int(round(10.0 / max(np.median(np.diff(te)), 1e-3)))))
    low = np.array([np.convolve(dv[:, j], np.ones(k) / k, mode="valid") for j in range(3)]).T
    print(f"velocity error (IMU axes) rms [mm/s] {fmt(rms(dv), 1e3)}; its 10 s mean, rms "
          f"{fmt(rms(low), 1e3)}")
    return 0


if __name__ == "__main__":
    sys.exit(main(sys.argv))
