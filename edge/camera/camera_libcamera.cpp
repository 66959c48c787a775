// The "libcamera" camera backend: a C++17 shim over libcamera 0.3 (the API family current Raspberry Pi
// OS ships) behind the C vc_camera_backend interface.
//
// One CameraManager per process (libcamera allows no more), shared by the node's two cameras and
// released with the last. open: pick the camera by id or index, acquire it, configure one Viewfinder
// stream at the requested size in an RGB layout (BGR888 = R,G,B bytes preferred; RGB888, XBGR/XRGB8888,
// YUYV converted), allocate and mmap the buffers, one Request per buffer. start: the ControlList that
// makes a triggered sensor behave — FrameDurationLimits fixed to the trigger period, AeEnable off and
// ExposureTime fixed — then queue every request. Completed requests (libcamera's thread) go into a
// queue the capture call waits on; each is converted, then reused and requeued. Timestamps: the
// request's SensorTimestamp is CLOCK_BOOTTIME and goes through vc_clock; without it the buffer's V4L2
// timestamp (CLOCK_MONOTONIC) is used. Limits: one stream per camera, no Bayer/raw capture, no
// multi-planar layouts.
#include <libcamera/camera.h>
#include <libcamera/camera_manager.h>
#include <libcamera/control_ids.h>
#include <libcamera/controls.h>
#include <libcamera/formats.h>
#include <libcamera/framebuffer.h>
#include <libcamera/framebuffer_allocator.h>
#include <libcamera/request.h>
#include <libcamera/stream.h>
#include <sys/mman.h>
#include <unistd.h>

#include <cerrno>
#include <chrono>
#include <condition_variable>
#include <cstdlib>
#include <cstring>
#include <deque>
#include <map>
#include <memory>
#include <mutex>
#include <string>
#include <vector>

#include "libcamera_util.hpp"
#include "voxcap/edge/camera_backend.h"
#include "voxcap/edge/clock.h"

namespace vc::edgecam {
namespace {

namespace lc = libcamera;

// The process-wide CameraManager, started on first use and stopped with the last user.
std::shared_ptr<lc::CameraManager> acquire_manager(int* rc) {
  static std::mutex mu;
  static std::weak_ptr<lc::CameraManager> shared;
  std::lock_guard<std::mutex> lock(mu);
  if (auto mgr = shared.lock()) {
    *rc = 0;
    return mgr;
  }
  // libcamera logs INFO lines to stderr by default; keep errors only unless the user chose otherwise
  setenv("LIBCAMERA_LOG_LEVELS", "*:ERROR", 0);
  // ~CameraManager() stops it
  auto mgr = std::make_shared<lc::CameraManager>();
  *rc = mgr->start();
  if (*rc) return nullptr;
  shared = mgr;
  return mgr;
}

struct Mapping {
  void* base = MAP_FAILED;
  size_t length = 0;
  const uint8_t* data = nullptr;
};

struct LcCamera {
  vc_camera* cam = nullptr;
  std::shared_ptr<lc::CameraManager> mgr;
  std::shared_ptr<lc::Camera> camera;
  bool acquired = false;
  std::unique_ptr<lc::CameraConfiguration> config;
  lc::Stream* stream = nullptr;
  std::unique_ptr<lc::FrameBufferAllocator> allocator;
  std::vector<std::unique_ptr<lc::Request>> requests;
  std::map<const lc::FrameBuffer*, Mapping> maps;
  Layout layout = Layout::kUnsupported;
  vc_yuv_coeffs yuv{};
  int width = 0, height = 0;
  unsigned stride = 0;
  lc::ControlList start_controls;
  bool running = false;
  vc_clock_converter boottime{};
  bool have_seq = false;
  uint32_t last_seq32 = 0;
  uint64_t seq_hi = 0;

  std::mutex mu;
  std::condition_variable cv;
  std::deque<lc::Request*> done;
  bool disconnected = false;

  void on_request_completed(lc::Request* req) {
    if (req->status() == lc::Request::RequestCancelled) return;  // stop(): requeued at the next start
    {
      std::lock_guard<std::mutex> lock(mu);
      done.push_back(req);
    }
    cv.notify_one();
  }
  void on_disconnected() {
    {
      std::lock_guard<std::mutex> lock(mu);
      disconnected = true;
    }
    cv.notify_all();
  }

  ~LcCamera() {
    if (running && camera) camera->stop();
    if (camera) {
      camera->requestCompleted.disconnect(this);
      camera->disconnected.disconnect(this);
    }
    requests.clear();
    for (auto& [buf, m] : maps)
      if (m.base != MAP_FAILED) munmap(m.base, m.length);
    if (allocator && stream) allocator->free(stream);
    allocator.reset();
    config.reset();
    if (acquired) camera->release();
    camera.reset();
    mgr.reset();  // the last camera stops the manager
  }
};

int fail(vc_camera* cam, int code, const std::string& msg) {
  return vc_camera_set_error(cam, code, "%s", msg.c_str());
}

int lc_open(vc_camera* cam, const vc_camera_config* cfg, vc_camera_info* info, void** out) {
  *out = nullptr;
  if (cfg->external_trigger && cfg->exposure_us <= 0)
    return fail(cam, -EINVAL, "an externally triggered sensor needs a fixed exposure_us");
  auto c = std::make_unique<LcCamera>();
  c->cam = cam;
  int rc = vc_clock_converter_init(&c->boottime, VC_CLOCK_BOOTTIME, 0);
  if (rc) return fail(cam, rc, "cannot read CLOCK_BOOTTIME");
  c->mgr = acquire_manager(&rc);
  if (!c->mgr)
    return fail(cam, rc < 0 ? rc : -EIO, std::string("camera manager failed to start: ") + strerror(-rc));

  std::vector<std::shared_ptr<lc::Camera>> cams = c->mgr->cameras();
  std::vector<std::string> ids;
  for (const auto& cm : cams) ids.push_back(cm->id());
  std::string why;
  int idx = pick_camera(ids, cfg->device ? cfg->device : "", &why);
  if (idx < 0) return fail(cam, -ENOENT, why);
  c->camera = cams[(size_t)idx];
  snprintf(info->driver, sizeof info->driver, "%s", c->camera->id().c_str());
  if (c->camera->acquire() != 0) return fail(cam, -EBUSY, "camera " + c->camera->id() + " is in use");
  c->acquired = true;

  c->config = c->camera->generateConfiguration({lc::StreamRole::Viewfinder});
  if (!c->config || c->config->size() != 1) return fail(cam, -ENOTSUP, "camera offers no viewfinder stream");
  lc::StreamConfiguration& sc = c->config->at(0);
  if (cfg->width > 0) sc.size = lc::Size((unsigned)cfg->width, (unsigned)cfg->height);
  sc.bufferCount = cfg->buffers ? cfg->buffers : 4;
  // the first RGB-ish layout the stream offers; validate() may still adjust
  std::vector<lc::PixelFormat> offered = sc.formats().pixelformats();
  sc.pixelFormat = lc::formats::BGR888;
  for (const auto& f : preferred_formats()) {
    bool found = false;
    for (const auto& o : offered) found = found || o == f;
    if (found) {
      sc.pixelFormat = f;
      break;
    }
  }
  if (c->config->validate() == lc::CameraConfiguration::Invalid)
    return fail(cam, -ENOTSUP, "stream configuration " + sc.toString() + " is invalid");
  c->layout = layout_of(sc.pixelFormat);
  if (c->layout == Layout::kUnsupported)
    return fail(cam, -ENOTSUP,
                "format " + sc.pixelFormat.toString() +
                    " not supported (need BGR888, RGB888, "
                    "XBGR8888, XRGB8888 or YUYV)");
  if (cfg->width > 0 && (sc.size.width != (unsigned)cfg->width || sc.size.height != (unsigned)cfg->height))
    return fail(cam, -ENOTSUP,
                "size " + std::to_string(cfg->width) + "x" + std::to_string(cfg->height) +
                    " not supported (camera offers " + sc.size.toString() + ")");
  if (c->camera->configure(c->config.get()) != 0)
    return fail(cam, -EIO, "configure " + sc.toString() + " failed");
  c->stream = sc.stream();
  c->width = (int)sc.size.width;
  c->height = (int)sc.size.height;
  c->stride = sc.stride;
  {
    bool full = sc.colorSpace && sc.colorSpace->range == lc::ColorSpace::Range::Full;
    bool bt709 = sc.colorSpace && sc.colorSpace->ycbcrEncoding == lc::ColorSpace::YcbcrEncoding::Rec709;
    vc_yuv_coeffs_init(&c->yuv, bt709 ? VC_YUV_BT709 : VC_YUV_BT601, full);
  }

  c->allocator = std::make_unique<lc::FrameBufferAllocator>(c->camera);
  if (c->allocator->allocate(c->stream) < 0) return fail(cam, -ENOMEM, "cannot allocate frame buffers");
  for (const auto& buf : c->allocator->buffers(c->stream)) {
    const lc::FrameBuffer::Plane& plane = buf->planes()[0];
    const long page = sysconf(_SC_PAGESIZE);
    const size_t aligned = plane.offset / (size_t)page * (size_t)page;
    Mapping m;
    m.length = plane.offset - aligned + plane.length;
    m.base = mmap(nullptr, m.length, PROT_READ, MAP_SHARED, plane.fd.get(), (off_t)aligned);
    if (m.base == MAP_FAILED)
      return fail(cam, -errno, std::string("mmap of a frame buffer: ") + strerror(errno));
    m.data = static_cast<const uint8_t*>(m.base) + (plane.offset - aligned);
    c->maps[buf.get()] = m;
    if ((size_t)c->stride * (size_t)(c->height - 1) + (size_t)c->width > plane.length)
      return fail(cam, -EIO, "frame buffer smaller than the configured frame");
    std::unique_ptr<lc::Request> req = c->camera->createRequest(c->requests.size());
    if (!req || req->addBuffer(c->stream, buf.get()) != 0) return fail(cam, -EIO, "cannot create a request");
    c->requests.push_back(std::move(req));
  }

  // controls for start(): a triggered sensor needs a fixed frame duration and a fixed exposure
  c->start_controls = lc::ControlList(c->camera->controls());
  const lc::ControlInfoMap& ctrls = c->camera->controls();
  const int64_t duration_us = frame_duration_us(cfg->fps_num, cfg->fps_den);
  if (duration_us > 0) {
    if (!ctrls.count(lc::controls::FrameDurationLimits.id()))
      return fail(cam, -ENOTSUP, "camera has no FrameDurationLimits control: the frame rate cannot be fixed");
    c->start_controls.set(lc::controls::FrameDurationLimits, {duration_us, duration_us});
    info->fps_num = cfg->fps_num;
    info->fps_den = cfg->fps_den ? cfg->fps_den : 1;
  }
  if (cfg->exposure_us > 0) {
    if (!ctrls.count(lc::controls::ExposureTime.id()))
      return fail(cam, -ENOTSUP, "camera has no ExposureTime control: the exposure cannot be fixed");
    if (ctrls.count(lc::controls::AeEnable.id())) c->start_controls.set(lc::controls::AeEnable, false);
    c->start_controls.set(lc::controls::ExposureTime, (int32_t)cfg->exposure_us);
  }
  if (cfg->n_controls)
    return fail(cam, -ENOTSUP,
                "device controls by name are a v4l2 backend feature; use exposure_us/fps here");

  c->camera->requestCompleted.connect(c.get(), &LcCamera::on_request_completed);
  c->camera->disconnected.connect(c.get(), &LcCamera::on_disconnected);
  info->width = c->width;
  info->height = c->height;
  info->pixfmt = pixfmt_of(c->layout);
  info->buffers = (unsigned)c->requests.size();
  *out = c.release();
  return 0;
}

int lc_start(vc_camera* cam, void* p) {
  auto* c = static_cast<LcCamera*>(p);
  {
    std::lock_guard<std::mutex> lock(c->mu);
    c->done.clear();
  }
  if (c->camera->start(&c->start_controls) != 0) return fail(cam, -EIO, "camera start failed");
  c->running = true;
  c->have_seq = false;
  c->seq_hi = 0;
  for (auto& req : c->requests) {
    req->reuse(lc::Request::ReuseBuffers);
    if (c->camera->queueRequest(req.get()) != 0) return fail(cam, -EIO, "queueing a request failed");
  }
  return 0;
}

int lc_stop(vc_camera* cam, void* p) {
  auto* c = static_cast<LcCamera*>(p);
  if (!c->running) return 0;
  c->running = false;
  if (c->camera->stop() != 0) return fail(cam, -EIO, "camera stop failed");
  std::lock_guard<std::mutex> lock(c->mu);
  c->done.clear();
  return 0;
}

int lc_capture(vc_camera* cam, void* p, int timeout_ms, uint8_t* rgb, size_t stride, vc_frame* meta) {
  auto* c = static_cast<LcCamera*>(p);
  const auto deadline =
      std::chrono::steady_clock::now() + std::chrono::milliseconds(timeout_ms < 0 ? 0 : timeout_ms);
  for (;;) {
    lc::Request* req = nullptr;
    {
      std::unique_lock<std::mutex> lock(c->mu);
      auto ready = [&] { return !c->done.empty() || c->disconnected; };
      if (timeout_ms < 0)
        c->cv.wait(lock, ready);
      else if (!c->cv.wait_until(lock, deadline, ready))
        return vc_camera_set_error(cam, -ETIMEDOUT, "camera stopped delivering: no frame within %d ms",
                                   timeout_ms);
      if (c->disconnected) return vc_camera_set_error(cam, -ENODEV, "camera disconnected");
      req = c->done.front();
      c->done.pop_front();
    }
    lc::FrameBuffer* buf = req->findBuffer(c->stream);
    bool ok = buf && buf->metadata().status == lc::FrameMetadata::FrameSuccess && c->maps.count(buf);
    if (ok) {
      convert(c->layout, c->maps[buf].data, c->stride, rgb, stride, c->width, c->height, &c->yuv);
      std::optional<int64_t> sensor_ts = req->metadata().get(lc::controls::SensorTimestamp);
      if (sensor_ts && *sensor_ts > 0)
        meta->t_ns = vc_clock_to_monotonic(&c->boottime, (uint64_t)*sensor_ts);
      else
        meta->t_ns = buf->metadata().timestamp;  // the V4L2 buffer time: CLOCK_MONOTONIC
      meta->flags = VC_FRAME_TS_DRIVER;
      uint32_t seq32 = buf->metadata().sequence;
      if (c->have_seq && seq32 < c->last_seq32) c->seq_hi += 1ull << 32;
      c->have_seq = true;
      c->last_seq32 = seq32;
      meta->sequence = c->seq_hi | seq32;
      meta->index = meta->sequence;
    } else {
      vc_camera_count_corrupted(cam);
    }
    req->reuse(lc::Request::ReuseBuffers);
    if (c->running && c->camera->queueRequest(req) != 0)
      return fail(cam, -EIO, "requeueing a request failed");
    if (ok) return 0;
  }
}

void lc_free(void* p) {
  delete static_cast<LcCamera*>(p);
}

}  // namespace
}  // namespace vc::edgecam

extern "C" const vc_camera_backend vc_camera_backend_libcamera = {
    "libcamera",
    vc::edgecam::lc_open,
    vc::edgecam::lc_start,
    vc::edgecam::lc_capture,
    vc::edgecam::lc_stop,
    vc::edgecam::lc_free,
    nullptr,
    nullptr,
    nullptr,
};
