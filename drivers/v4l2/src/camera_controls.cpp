#include "vilma/drivers/v4l2/camera_controls.h"

#include <linux/videodev2.h>

#include <cctype>
#include <cmath>
#include <sstream>

namespace vilma::v4l2 {
namespace {

struct ControlInfo {
  v4l2_queryctrl query{};
  std::string key;
};

std::vector<ControlInfo> EnumerateControls(V4l2Io* io, int fd) {
  std::vector<ControlInfo> controls;
  v4l2_queryctrl query{};
  query.id = V4L2_CTRL_FLAG_NEXT_CTRL;
  for (int guard = 0; guard < 1024 && io->Ioctl(fd, VIDIOC_QUERYCTRL, &query) == 0; ++guard) {
    const bool skip =
        (query.flags & V4L2_CTRL_FLAG_DISABLED) != 0 || query.type == V4L2_CTRL_TYPE_CTRL_CLASS;
    if (!skip) {
      ControlInfo info;
      info.query = query;
      info.key = ControlKey(FieldText(query.name));
      controls.push_back(info);
    }
    query.id |= V4L2_CTRL_FLAG_NEXT_CTRL;
  }
  return controls;
}

const ControlInfo* FindById(const std::vector<ControlInfo>& controls, uint32_t id) {
  for (const ControlInfo& c : controls) {
    if (c.query.id == id) return &c;
  }
  return nullptr;
}

bool MenuHas(V4l2Io* io, int fd, uint32_t id, int64_t index) {
  v4l2_querymenu menu{};
  menu.id = id;
  menu.index = static_cast<uint32_t>(index);
  return io->Ioctl(fd, VIDIOC_QUERYMENU, &menu) == 0;
}

std::string RangeText(const v4l2_queryctrl& q) {
  std::ostringstream s;
  s << q.minimum << ".." << q.maximum;
  if (q.step > 1) s << " step " << q.step;
  return s.str();
}

// Checks `value` against the control's range (and menu) and sets it.
std::string SetControl(V4l2Io* io, int fd, const ControlInfo& control, int64_t value) {
  const v4l2_queryctrl& q = control.query;
  if ((q.flags & V4L2_CTRL_FLAG_READ_ONLY) != 0) return control.key + " is read-only";
  if (value < q.minimum || value > q.maximum) {
    return control.key + "=" + std::to_string(value) + " is out of range " + RangeText(q);
  }
  if ((q.type == V4L2_CTRL_TYPE_MENU || q.type == V4L2_CTRL_TYPE_INTEGER_MENU) &&
      !MenuHas(io, fd, q.id, value)) {
    return control.key + "=" + std::to_string(value) + " is not an item of its menu";
  }
  v4l2_control c{};
  c.id = q.id;
  c.value = static_cast<int32_t>(value);
  const int result = io->Ioctl(fd, VIDIOC_S_CTRL, &c);
  if (result != 0) {
    return "setting " + control.key + "=" + std::to_string(value) + " failed: " + ErrnoText(result);
  }
  return "";
}

}  // namespace

std::string ControlOptions::Validate() const {
  if (!(std::isfinite(exposure_us) && exposure_us >= 0.0 && exposure_us <= 1e7)) {
    return "exposure: expected auto or 1 .. 10000000 [us]";
  }
  if (gain < -1) return "gain: expected auto or >= 0";
  for (const auto& entry : controls) {
    if (entry.first.empty() || ControlKey(entry.first) != entry.first) {
      return "controls." + entry.first +
             ": expected a v4l2-ctl control name (lower case, digits, '_')";
    }
  }
  return "";
}

std::string ControlKey(const std::string& name) {
  std::string key;
  for (char c : name) {
    if (std::isalnum(static_cast<unsigned char>(c))) {
      key += static_cast<char>(std::tolower(static_cast<unsigned char>(c)));
    } else if (!key.empty() && key.back() != '_') {
      key += '_';
    }
  }
  while (!key.empty() && key.back() == '_') key.pop_back();
  return key;
}

std::string ApplyControls(V4l2Io* io, int fd, const ControlOptions& options,
                          ControlReport* report) {
  *report = ControlReport{};
  const std::vector<ControlInfo> controls = EnumerateControls(io, fd);
  const ControlInfo* exposure_auto = FindById(controls, V4L2_CID_EXPOSURE_AUTO);
  const ControlInfo* exposure_absolute = FindById(controls, V4L2_CID_EXPOSURE_ABSOLUTE);

  if (options.exposure_us > 0.0) {
    if (exposure_absolute == nullptr) {
      return "exposure: a fixed exposure needs the control exposure_time_absolute, which this "
             "camera does not have (--list shows its controls)";
    }
    if (exposure_auto != nullptr) {
      const std::string error = SetControl(io, fd, *exposure_auto, V4L2_EXPOSURE_MANUAL);
      if (!error.empty()) return "exposure: " + error;
    }
    // 100 us units, on the control's step grid.
    const v4l2_queryctrl& q = exposure_absolute->query;
    const int64_t step = q.step > 0 ? q.step : 1;
    int64_t value = std::llround(options.exposure_us / 100.0);
    value = q.minimum + std::llround(static_cast<double>(value - q.minimum) / step) * step;
    if (value < q.minimum || value > q.maximum) {
      std::ostringstream s;
      s << "exposure: " << options.exposure_us << " us is outside the camera's range "
        << q.minimum * 100 << ".." << q.maximum * 100 << " us";
      return s.str();
    }
    const std::string error = SetControl(io, fd, *exposure_absolute, value);
    if (!error.empty()) return "exposure: " + error;
    report->exposure_us = ReadExposureUs(io, fd);
    report->applied.push_back("exposure_time_absolute=" + std::to_string(value) + " (" +
                              std::to_string(report->exposure_us) + " us)");
  } else if (exposure_auto != nullptr) {
    // Full auto where the menu has it, else aperture priority (auto time, fixed iris).
    const int64_t mode = MenuHas(io, fd, V4L2_CID_EXPOSURE_AUTO, V4L2_EXPOSURE_AUTO)
                             ? V4L2_EXPOSURE_AUTO
                             : V4L2_EXPOSURE_APERTURE_PRIORITY;
    const std::string error = SetControl(io, fd, *exposure_auto, mode);
    if (!error.empty()) return "exposure: " + error;
    report->applied.push_back("auto_exposure=" + std::to_string(mode));
  } else {
    report->warnings.push_back("the camera has no auto_exposure control: exposure left as it is");
  }

  const ControlInfo* autogain = FindById(controls, V4L2_CID_AUTOGAIN);
  const ControlInfo* gain = FindById(controls, V4L2_CID_GAIN);
  if (autogain != nullptr) {
    const std::string error = SetControl(io, fd, *autogain, options.gain < 0 ? 1 : 0);
    if (!error.empty()) return "gain: " + error;
  }
  if (options.gain >= 0) {
    if (gain == nullptr) {
      return "gain: a fixed gain needs the control gain, which this camera does not have";
    }
    const std::string error = SetControl(io, fd, *gain, options.gain);
    if (!error.empty()) return "gain: " + error;
    report->applied.push_back("gain=" + std::to_string(options.gain));
  }

  for (const auto& entry : options.controls) {
    const ControlInfo* control = nullptr;
    for (const ControlInfo& c : controls) {
      if (c.key == entry.first) control = &c;
    }
    if (control == nullptr) {
      report->warnings.push_back("the camera has no control '" + entry.first + "' (ignored)");
      continue;
    }
    const std::string error = SetControl(io, fd, *control, entry.second);
    if (!error.empty()) return "controls." + error;
    report->applied.push_back(entry.first + "=" + std::to_string(entry.second));
  }
  return "";
}

int64_t ReadExposureUs(V4l2Io* io, int fd) {
  v4l2_control c{};
  c.id = V4L2_CID_EXPOSURE_ABSOLUTE;
  if (io->Ioctl(fd, VIDIOC_G_CTRL, &c) != 0) return 0;
  return static_cast<int64_t>(c.value) * 100;
}

std::string DescribeControls(V4l2Io* io, int fd) {
  std::ostringstream out;
  for (const ControlInfo& c : EnumerateControls(io, fd)) {
    const v4l2_queryctrl& q = c.query;
    const char* type = "int";
    switch (q.type) {
      case V4L2_CTRL_TYPE_BOOLEAN:
        type = "bool";
        break;
      case V4L2_CTRL_TYPE_MENU:
        type = "menu";
        break;
      case V4L2_CTRL_TYPE_INTEGER_MENU:
        type = "intmenu";
        break;
      case V4L2_CTRL_TYPE_BUTTON:
        type = "button";
        break;
      case V4L2_CTRL_TYPE_INTEGER64:
        type = "int64";
        break;
      default:
        break;
    }
    out << "    " << c.key << " (" << type << ") " << RangeText(q) << " default "
        << q.default_value;
    v4l2_control value{};
    value.id = q.id;
    if (q.type != V4L2_CTRL_TYPE_BUTTON && io->Ioctl(fd, VIDIOC_G_CTRL, &value) == 0) {
      out << " value " << value.value;
    }
    if (q.id == V4L2_CID_EXPOSURE_ABSOLUTE) out << " [100 us]";
    if ((q.flags & V4L2_CTRL_FLAG_INACTIVE) != 0) out << " inactive";
    if ((q.flags & V4L2_CTRL_FLAG_READ_ONLY) != 0) out << " read-only";
    out << "\n";
    if (q.type == V4L2_CTRL_TYPE_MENU) {
      // Menus are short; the bound guards against a driver reporting a huge range.
      for (int64_t i = q.minimum; i <= q.maximum && i - q.minimum < 256; ++i) {
        v4l2_querymenu menu{};
        menu.id = q.id;
        menu.index = static_cast<uint32_t>(i);
        if (io->Ioctl(fd, VIDIOC_QUERYMENU, &menu) == 0) {
          out << "      " << i << ": " << FieldText(menu.name) << "\n";
        }
      }
    }
  }
  return out.str();
}

}  // namespace vilma::v4l2
