// vilma-v4l2: format negotiation and camera controls against the fake camera
// (drivers/v4l2/src/format_negotiation.cpp, camera_controls.cpp), and the fake's own V4L2
// semantics that the capture loop relies on.
#include <catch2/catch.hpp>

#include "test_skip.h"

#ifdef VILMA_HAVE_DRIVER_V4L2
#include <linux/videodev2.h>

#include <cerrno>

#include "vilma/drivers/v4l2/camera_controls.h"
#include "vilma/drivers/v4l2/device_list.h"
#include "vilma/drivers/v4l2/fake_v4l2_io.h"
#include "vilma/drivers/v4l2/format_negotiation.h"

namespace vilma::v4l2 {
namespace {

bool Contains(const std::string& text, const std::string& part) {
  return text.find(part) != std::string::npos;
}

TEST_CASE("v4l2 the first preferred format the camera offers is chosen, at the nearest size",
          "[v4l2]") {
  FakeV4l2Io fake;
  const int fd = fake.Open("/dev/video0");
  REQUIRE(fd >= 0);
  FormatRequest request;
  request.fourccs = {V4L2_PIX_FMT_Y16, V4L2_PIX_FMT_GREY};
  request.width = 640;
  request.height = 480;
  request.fps = 15;
  NegotiatedFormat format;
  REQUIRE(NegotiateFormat(&fake, fd, request, &format).empty());
  CHECK(format.fourcc == V4L2_PIX_FMT_Y16);
  CHECK(format.width == 640);
  CHECK(format.bytes_per_line == 1280);
  CHECK(format.size_image == 1280u * 480u);
  CHECK(format.fps == Approx(15.0));
  CHECK(format.notes.empty());

  // 700x470 is not offered: GREY's nearest is 752x480 (a note, or an error when required).
  request.fourccs = {V4L2_PIX_FMT_RGB24, V4L2_PIX_FMT_GREY};
  request.width = 740;
  request.height = 470;
  request.fps = 25;
  REQUIRE(NegotiateFormat(&fake, fd, request, &format).empty());
  CHECK(format.fourcc == V4L2_PIX_FMT_GREY);
  CHECK(format.width == 752);
  CHECK(format.height == 480);
  CHECK(format.fps == Approx(30.0));
  REQUIRE(format.notes.size() == 2);
  CHECK(Contains(format.notes[0], "asked for 740x470, the device set 752x480"));
  CHECK(Contains(format.notes[0], "640x480, 752x480, 320x240"));
  CHECK(Contains(format.notes[1], "asked for 25 fps, the device set 30 fps"));
  CHECK(Contains(format.notes[1], "60, 30, 20, 15 fps"));

  request.require_size = true;
  CHECK(Contains(NegotiateFormat(&fake, fd, request, &format), "asked for 740x470"));
  request.require_size = false;
  request.require_fps = true;
  CHECK(Contains(NegotiateFormat(&fake, fd, request, &format), "asked for 25 fps"));

  // Nothing in common: the error lists both sides.
  request = FormatRequest{};
  request.fourccs = {V4L2_PIX_FMT_RGB24};
  const std::string error = NegotiateFormat(&fake, fd, request, &format);
  CHECK(Contains(error, "GREY, Y16, YUYV, MJPG"));
  CHECK(Contains(error, "none of RGB3"));
  fake.Close(fd);
}

TEST_CASE("v4l2 width and height 0 keep the camera's current size", "[v4l2]") {
  FakeV4l2Io fake;
  const int fd = fake.Open("/dev/video0");
  FormatRequest request;
  request.fourccs = {V4L2_PIX_FMT_MJPEG};
  NegotiatedFormat format;
  REQUIRE(NegotiateFormat(&fake, fd, request, &format).empty());
  CHECK(format.fourcc == V4L2_PIX_FMT_MJPEG);
  CHECK(format.width == 640);  // the GREY default size, which MJPG also has
  CHECK(format.bytes_per_line == 0);
  CHECK(format.fps == Approx(30.0));  // 60 is not an MJPG rate: the first MJPG one
}

TEST_CASE("v4l2 fixed exposure switches auto exposure off first and counts 100 us units",
          "[v4l2]") {
  FakeV4l2Io fake;
  const int fd = fake.Open("/dev/video0");
  // The fake refuses an absolute exposure while auto exposure is on (as UVC cameras do).
  v4l2_control direct{V4L2_CID_EXPOSURE_ABSOLUTE, 50};
  CHECK(fake.Ioctl(fd, VIDIOC_S_CTRL, &direct) == -EACCES);

  ControlOptions options;
  options.exposure_us = 5000;
  options.gain = 40;
  options.controls = {{"brightness", -10}, {"white_balance_automatic", 1}};
  ControlReport report;
  REQUIRE(ApplyControls(&fake, fd, options, &report).empty());
  CHECK(fake.ControlValue(V4L2_CID_EXPOSURE_AUTO) == V4L2_EXPOSURE_MANUAL);
  CHECK(fake.ControlValue(V4L2_CID_EXPOSURE_ABSOLUTE) == 50);
  CHECK(report.exposure_us == 5000);
  CHECK(fake.ControlValue(V4L2_CID_GAIN) == 40);
  CHECK(fake.ControlValue(V4L2_CID_BRIGHTNESS) == -10);
  REQUIRE(report.warnings.size() == 1);
  CHECK(Contains(report.warnings[0], "'white_balance_automatic'"));
  CHECK(ReadExposureUs(&fake, fd) == 5000);

  // 1234 us -> 12 units (1200 us).
  options = ControlOptions{};
  options.exposure_us = 1234;
  REQUIRE(ApplyControls(&fake, fd, options, &report).empty());
  CHECK(fake.ControlValue(V4L2_CID_EXPOSURE_ABSOLUTE) == 12);
  CHECK(report.exposure_us == 1200);

  // Auto again: the camera's menu has no full auto, so aperture priority.
  REQUIRE(ApplyControls(&fake, fd, ControlOptions{}, &report).empty());
  CHECK(fake.ControlValue(V4L2_CID_EXPOSURE_AUTO) == V4L2_EXPOSURE_APERTURE_PRIORITY);
  CHECK(report.exposure_us == 0);
}

TEST_CASE("v4l2 control values outside the camera's range are errors naming the range", "[v4l2]") {
  FakeV4l2Io fake;
  const int fd = fake.Open("/dev/video0");
  ControlOptions options;
  options.exposure_us = 600000;  // 6000 units > 5000
  ControlReport report;
  CHECK(Contains(ApplyControls(&fake, fd, options, &report),
                 "outside the camera's range 100..500000 us"));
  options = ControlOptions{};
  options.gain = 101;
  CHECK(Contains(ApplyControls(&fake, fd, options, &report), "gain=101 is out of range 0..100"));
  options = ControlOptions{};
  options.controls = {{"auto_exposure", 2}};  // not an item of the menu
  CHECK(Contains(ApplyControls(&fake, fd, options, &report), "not an item of its menu"));
}

TEST_CASE("v4l2 control names follow v4l2-ctl", "[v4l2]") {
  CHECK(ControlKey("Exposure Time, Absolute") == "exposure_time_absolute");
  CHECK(ControlKey("White Balance Temperature, Auto") == "white_balance_temperature_auto");
  CHECK(ControlKey("Power Line Frequency") == "power_line_frequency");
  ControlOptions o;
  o.controls = {{"Brightness", 1}};
  CHECK(Contains(o.Validate(), "controls.Brightness"));
}

TEST_CASE("v4l2 the device listing (--list) shows nodes, names, formats, sizes, rates and controls",
          "[v4l2]") {
  FakeV4l2Io fake;
  int capture_nodes = 0;
  const std::string text = ListDevices(&fake, &capture_nodes);
  CHECK(capture_nodes == 1);
  CHECK(Contains(text,
                 "/dev/video0\n  name: /dev/v4l/by-id/usb-vilma_Fake_Camera_0001-video-index0"));
  CHECK(Contains(text, "card: vilma fake camera"));
  CHECK(Contains(text, "    MJPG: 1280x720, 640x480\n      1280x720: 30, 15 fps"));
  CHECK(Contains(text,
                 "exposure_time_absolute (int) 1..5000 default 156 value 156 [100 us] inactive"));
  CHECK(Contains(text, "      1: Manual Mode"));
  CHECK(Contains(text, "/dev/video1\n  driver: vilma-fake"));
  CHECK(Contains(text, "not a video capture node (metadata node)"));

  fake.Unplug(60.0);
  CHECK(Contains(ListDevices(&fake, &capture_nodes), "/dev/video* is absent"));
  CHECK(capture_nodes == 0);

  FakeCameraSpec spec;
  spec.multiplanar = true;
  FakeV4l2Io mplane(spec);
  const std::string mplane_text = ListDevices(&mplane, &capture_nodes);
  CHECK(capture_nodes == 1);
  CHECK(Contains(mplane_text, "  capture (multi-planar API), streaming"));
  CHECK(Contains(mplane_text, "current format: GREY 640x480"));
  CHECK(Contains(mplane_text, "    YUYV: 640x480, 320x240"));
}

TEST_CASE("v4l2 the fake follows the kernel's buffer queue rules", "[v4l2]") {
  FakeV4l2Io fake;
  const int fd = fake.Open("/dev/video0");
  v4l2_requestbuffers request{};
  request.type = V4L2_BUF_TYPE_VIDEO_CAPTURE;
  request.memory = V4L2_MEMORY_USERPTR;
  request.count = 3;
  CHECK(fake.Ioctl(fd, VIDIOC_REQBUFS, &request) == -EINVAL);  // MMAP only
  request.memory = V4L2_MEMORY_MMAP;
  REQUIRE(fake.Ioctl(fd, VIDIOC_REQBUFS, &request) == 0);
  CHECK(request.count == 3);
  // No S_FMT with buffers allocated, no second owner.
  v4l2_format format{};
  format.type = V4L2_BUF_TYPE_VIDEO_CAPTURE;
  REQUIRE(fake.Ioctl(fd, VIDIOC_G_FMT, &format) == 0);
  CHECK(fake.Ioctl(fd, VIDIOC_S_FMT, &format) == -EBUSY);
  const int other = fake.Open("/dev/v4l/by-id/usb-vilma_Fake_Camera_0001-video-index0");
  CHECK(fake.Ioctl(other, VIDIOC_REQBUFS, &request) == -EBUSY);
  // A buffer queued twice, DQBUF before STREAMON.
  v4l2_buffer buffer{};
  buffer.type = V4L2_BUF_TYPE_VIDEO_CAPTURE;
  buffer.memory = V4L2_MEMORY_MMAP;
  buffer.index = 0;
  REQUIRE(fake.Ioctl(fd, VIDIOC_QUERYBUF, &buffer) == 0);
  void* mapped = fake.Map(fd, buffer.length, buffer.m.offset);
  REQUIRE(mapped != nullptr);
  REQUIRE(fake.Ioctl(fd, VIDIOC_QBUF, &buffer) == 0);
  CHECK(fake.Ioctl(fd, VIDIOC_QBUF, &buffer) == -EINVAL);
  CHECK(fake.Ioctl(fd, VIDIOC_DQBUF, &buffer) == -EINVAL);
  int type = V4L2_BUF_TYPE_VIDEO_CAPTURE;
  REQUIRE(fake.Ioctl(fd, VIDIOC_STREAMON, &type) == 0);
  CHECK(fake.Ioctl(fd, VIDIOC_DQBUF, &buffer) == -EAGAIN);  // nothing due yet (O_NONBLOCK)
  REQUIRE(fake.Poll(fd, 1000) == 1);
  REQUIRE(fake.Ioctl(fd, VIDIOC_DQBUF, &buffer) == 0);
  CHECK(buffer.sequence == 0);
  CHECK((buffer.flags & V4L2_BUF_FLAG_TIMESTAMP_MASK) == V4L2_BUF_FLAG_TIMESTAMP_MONOTONIC);
  CHECK((buffer.flags & V4L2_BUF_FLAG_TSTAMP_SRC_MASK) == V4L2_BUF_FLAG_TSTAMP_SRC_SOE);
  // Freeing mapped buffers is refused until they are unmapped.
  REQUIRE(fake.Ioctl(fd, VIDIOC_STREAMOFF, &type) == 0);
  request.count = 0;
  CHECK(fake.Ioctl(fd, VIDIOC_REQBUFS, &request) == -EBUSY);
  fake.Unmap(mapped, buffer.length);
  CHECK(fake.Ioctl(fd, VIDIOC_REQBUFS, &request) == 0);
  // Unplugged: every call on the open descriptor is ENODEV, the node is gone.
  fake.Unplug(60.0);
  CHECK(fake.Ioctl(fd, VIDIOC_QUERYCAP, &format) == -ENODEV);
  CHECK(fake.Poll(fd, 0) == -ENODEV);
  CHECK(fake.Open("/dev/video0") == -ENOENT);
  CHECK(fake.ResolveNode("/dev/v4l/by-id/usb-vilma_Fake_Camera_0001-video-index0").empty());
  fake.Close(fd);
  fake.Close(other);
}

}  // namespace
}  // namespace vilma::v4l2

#else
TEST_CASE("vilma-v4l2 negotiation and controls", "[v4l2]") {
  VILMA_SKIP("vilma-v4l2 is not built here (<linux/videodev2.h> missing)");
}
#endif
