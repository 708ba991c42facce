#include "input_stage.h"

#include <lcm/lcm-cpp.hpp>
#include <thread>

#include <vilma/image_t.hpp>
#include <vilma/imu_t.hpp>

#include "vilma/core/error.h"
#include "vilma/core/time.h"
#include "vilma/drivers/lcm_convert.h"
#include "vilma/drivers/lcm_log.h"
#include "vilma/drivers/lcm_url.h"
#include "vilma/mapstore/stream/mission_stream_sender.h"

namespace vilma::daemon {

struct InputStage::Lcm : MessageSink {
  InputStage* stage = nullptr;
  std::unique_ptr<lcm::LCM> input;       // live mode
  std::unique_ptr<LcmLogReader> reader;  // log mode
  std::unique_ptr<lcm::LCM> output;      // log mode: a separate instance for output
  lcm::LCM* publish = nullptr;
  image_t image_msg;  // reused: its data vector keeps its capacity
  imu_t imu_msg;

  void Publish(const std::string& channel, const void* data, int size) override {
    publish->publish(channel, data, static_cast<unsigned int>(size));
  }

  void OnMessage(const lcm::ReceiveBuffer* rbuf, const std::string& channel) {
    // Never throws: LCM would abort the handle loop (and the decoders return errors instead).
    try {
      stage->Dispatch(channel, rbuf->data, static_cast<int>(rbuf->data_size));
    } catch (const std::exception& e) {
      stage->p_.counters.Add(kLcmErrors);
      stage->p_.log(7, "handler error on %s: %s", channel.c_str(), e.what());
    }
  }
};

InputStage::InputStage(const DaemonOptions& options, const SensorRig& rig, int num_cameras,
                       Pipeline* pipeline, ImagePool* pool, Spsc<InputItem>* out)
    : rig_(rig),
      input_log_(options.input_log),
      log_slot_wait_s_(options.queues.log_slot_wait_s),
      p_(*pipeline),
      pool_(*pool),
      out_(*out),
      imu_channel_(ChannelName(options.channels.imu, options.channel_suffix)),
      lcm_(std::make_unique<Lcm>()) {
  for (int i = 0; i < num_cameras; ++i) {
    camera_channels_.push_back(
        ChannelName(options.channels.cameras[static_cast<std::size_t>(i)], options.channel_suffix));
  }
  lcm_->stage = this;
  const std::string url = ResolveLcmUrl(options.lcm_url);
  if (p_.log_mode) {
    lcm_->reader = std::make_unique<LcmLogReader>(options.input_log);
    lcm_->output = std::make_unique<lcm::LCM>(url);
    if (!lcm_->output->good()) {
      throw InputError(FormatInputError("--lcm-url", url, "an LCM URL that opens"));
    }
    lcm_->publish = lcm_->output.get();
  } else {
    lcm_->input = std::make_unique<lcm::LCM>(WithDefaultRecvBufSize(url));
    if (!lcm_->input->good()) {
      throw InputError(FormatInputError("--lcm-url", url, "an LCM URL that opens"));
    }
    lcm_->publish = lcm_->input.get();
    lcm_->input->subscribe(imu_channel_, &Lcm::OnMessage, lcm_.get());
    for (const std::string& channel : camera_channels_) {
      lcm_->input->subscribe(channel, &Lcm::OnMessage, lcm_.get());
    }
  }
}

InputStage::~InputStage() = default;

MessageSink& InputStage::sink() { return *lcm_; }

void InputStage::Close() {
  lcm_->publish = nullptr;
  lcm_->output.reset();
  lcm_->input.reset();
}

void InputStage::Dispatch(const std::string& channel, const void* data, int size) {
  const int64_t recv_ns = SteadyNs();
  const int64_t recv_wall_us = WallClockUtime();
  if (channel == imu_channel_) {
    HandleImu(data, size, recv_ns, recv_wall_us);
    return;
  }
  for (std::size_t i = 0; i < camera_channels_.size(); ++i) {
    if (channel == camera_channels_[i]) {
      HandleImage(static_cast<int>(i), data, size, recv_ns, recv_wall_us);
      return;
    }
  }
}

void InputStage::HandleImu(const void* data, int size, int64_t recv_ns, int64_t recv_wall_us) {
  p_.counters.Add(kImuReceived);
  InputItem item;
  const std::string error = DecodeImuMessage(data, size, &lcm_->imu_msg, &item.imu);
  if (!error.empty()) {
    p_.counters.Add(kMalformedImu);
    p_.log(0, "malformed message on %s: %s", imu_channel_.c_str(), error.c_str());
    return;
  }
  item.kind = InputItem::Kind::kImu;
  item.recv_steady_ns = recv_ns;
  item.recv_latency_us = recv_wall_us - lcm_->imu_msg.utime;
  if (!Push(p_, out_, item)) {
    p_.counters.Add(kImuDroppedInputQueue);
    p_.log(1, "BUG: input queue full, IMU sample dropped (queues.input_capacity)");
    return;
  }
  p_.sync_wake.Notify();
}

void InputStage::HandleImage(int camera, const void* data, int size, int64_t recv_ns,
                             int64_t recv_wall_us) {
  p_.counters.Add(kImagesReceived);
  const std::string& channel = camera_channels_[static_cast<std::size_t>(camera)];
  image_t& msg = lcm_->image_msg;
  std::string error = DecodeImageMessage(data, size, &msg);
  if (!error.empty()) {
    p_.counters.Add(kMalformedImages);
    p_.log(2, "malformed message on %s: %s", channel.c_str(), error.c_str());
    return;
  }
  const Camera& model = rig_.cameras[static_cast<std::size_t>(camera)].camera;
  if (msg.width != model.width() || msg.height != model.height()) {
    p_.counters.Add(kImagesWrongSize);
    p_.log(3, "image on %s is %dx%d, the rig's camera is %dx%d: dropped", channel.c_str(),
           msg.width, msg.height, model.width(), model.height());
    return;
  }
  cv::Mat slot = pool_.TryAcquire(msg.height, msg.width, CV_8UC1);
  if (slot.empty() && p_.log_mode) {
    // Blocking backpressure: a replay is loss-free however slow the stages are. Every release
    // frees a slot that this (the only acquiring) thread takes at once, so "no slot for
    // log_slot_wait_s" means nothing downstream released an image for that long: bounded so
    // that a logic error cannot hang the daemon. The wait is logged every 10 s.
    slot = pool_.AcquireWaiting(msg.height, msg.width, CV_8UC1, p_.stop, log_slot_wait_s_, 10.0,
                                [&](double waited_s) {
                                  p_.log(15, "waiting %.0f s for a free image slot (%s): the "
                                         "stages downstream are slow", waited_s, channel.c_str());
                                });
  }
  if (slot.empty()) {
    p_.counters.Add(kImagesDroppedPool);
    p_.log(4, "no free image slot: image on %s dropped", channel.c_str());
    return;
  }
  if (msg.pixel_format == image_t::GRAY8) {
    // The common case without a temporary: rows (row_stride may pad them) into the slot.
    const cv::Mat view(msg.height, msg.width, CV_8UC1, msg.data.data(),
                       static_cast<std::size_t>(msg.row_stride));
    view.copyTo(slot);
  } else {
    cv::Mat gray;
    error = MessageToGray8(msg, &gray);
    if (!error.empty()) {
      p_.counters.Add(kMalformedImages);
      p_.log(2, "malformed message on %s: %s", channel.c_str(), error.c_str());
      return;
    }
    gray.copyTo(slot);
  }
  InputItem item;
  item.kind = InputItem::Kind::kImage;
  item.camera = camera;
  item.t_cam_ns = UtimeToNs(msg.utime);
  item.recv_steady_ns = recv_ns;
  item.recv_latency_us = recv_wall_us - msg.utime;
  item.image = slot;
  if (!Push(p_, out_, item)) {
    p_.counters.Add(kImagesDroppedInputQueue);
    p_.log(5, "input queue full: image on %s dropped", channel.c_str());
    return;
  }
  p_.sync_wake.Notify();
}

void InputStage::Run() {
  if (p_.log_mode) {
    LcmLogEvent event;
    while (!p_.stop.load() && lcm_->reader->Next(&event)) {
      Dispatch(event.channel, event.data.data(), static_cast<int>(event.data.size()));
    }
  } else {
    while (!p_.stop.load()) {
      if (lcm_->input->handleTimeout(50) < 0) {
        p_.counters.Add(kLcmErrors);
        p_.log(6, "lcm handle failed");
        std::this_thread::sleep_for(std::chrono::milliseconds(10));
      }
    }
  }
  p_.input_done.store(true);
  p_.sync_wake.Notify();
}

namespace {

class LcmMissionStreamTransport : public MissionStreamTransport {
 public:
  explicit LcmMissionStreamTransport(const DaemonOptions& options) : options_(options) {
    const MapStreamOptions& so = options.mapping.stream;
    const std::string url = ResolveLcmUrl(so.lcm_url.empty() ? options.lcm_url : so.lcm_url);
    lcm_ = std::make_unique<lcm::LCM>(WithDefaultRecvBufSize(url));
    if (!lcm_->good()) {
      throw InputError(FormatInputError("daemon options", "mapping.stream.lcm_url",
                                        "an LCM URL that opens (" + url + ")"));
    }
    sender_options_.max_window_chunks = static_cast<std::size_t>(so.max_window_chunks);
    sender_options_.retransmit_timeout_s = so.retransmit_timeout_s;
    sender_options_.max_retransmit_timeout_s =
        std::max(sender_options_.max_retransmit_timeout_s, so.retransmit_timeout_s);
  }

  std::unique_ptr<mapstore::LcmMissionStreamSender> MakeSender(const mapstore::MissionId& id,
                                                              const std::string& name) override {
    const MapStreamOptions& so = options_.mapping.stream;
    return std::make_unique<mapstore::LcmMissionStreamSender>(
        lcm_.get(), ChannelName(so.chunk_channel, options_.channel_suffix),
        ChannelName(so.ack_channel, options_.channel_suffix), id, name, sender_options_);
  }

  int Handle(int timeout_ms) override { return lcm_->handleTimeout(timeout_ms); }

 private:
  const DaemonOptions options_;
  std::unique_ptr<lcm::LCM> lcm_;
  mapstore::MissionStreamSenderOptions sender_options_;
};

}  // namespace

std::unique_ptr<MissionStreamTransport> OpenMissionStreamTransport(const DaemonOptions& options) {
  return std::make_unique<LcmMissionStreamTransport>(options);
}

}  // namespace vilma::daemon
