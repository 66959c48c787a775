// Trigger output on a GPIO line through the libgpiod v2 API (the character device, not sysfs). The line
// is requested once as a push-pull output, initially inactive, with the kernel's active-low flag doing
// any inversion, so "active" always means "pulse". Edges are timed by the shared scheduler on the
// pulse thread; the library's error codes become TriggerErrors here and nowhere else.
#include "backends.hpp"
#include "voxcap/base/clock.hpp"

#include <gpiod.h>

#include <cerrno>
#include <cstring>

#include <fmt/format.h>

namespace vc::trigger::detail {
namespace {

template <typename T, void (*Free)(T*)>
struct Deleter {
  void operator()(T* p) const { Free(p); }
};
using LineSettings =
    std::unique_ptr<gpiod_line_settings, Deleter<gpiod_line_settings, gpiod_line_settings_free>>;
using LineConfig = std::unique_ptr<gpiod_line_config, Deleter<gpiod_line_config, gpiod_line_config_free>>;
using RequestConfig =
    std::unique_ptr<gpiod_request_config, Deleter<gpiod_request_config, gpiod_request_config_free>>;
using ChipInfo = std::unique_ptr<gpiod_chip_info, Deleter<gpiod_chip_info, gpiod_chip_info_free>>;
using LineInfo = std::unique_ptr<gpiod_line_info, Deleter<gpiod_line_info, gpiod_line_info_free>>;

std::string open_error(const std::string& path, int err) {
  switch (err) {
    case ENOENT:
      return fmt::format(
          "gpiod: no GPIO chip at {} (see `ls /dev/gpiochip*`; on a Raspberry Pi 5 the "
          "header's chip is gpiochip0 on recent kernels, gpiochip4 on older ones)",
          path);
    case EACCES:
    case EPERM:
      return fmt::format(
          "gpiod: permission denied opening {} (install hw/udev/60-voxcap.rules and join the "
          "plugdev group)",
          path);
    case ENOTTY:
    case ENODEV:
    case EINVAL:
      return fmt::format("gpiod: {} is not a GPIO chip", path);
    default:
      return fmt::format("gpiod: cannot open {}: {}", path, std::strerror(err));
  }
}

}  // namespace

GpiodGenerator::GpiodGenerator(const config::TriggerOptions& options)
    : ScheduledGenerator(options), gpio_(options.gpiod), active_low_(options.active_low) {}

GpiodGenerator::~GpiodGenerator() {
  stop();
  release();
}

std::string GpiodGenerator::describe() const {
  return fmt::format("gpiod {} line {}{}", gpio_.chip_path().string(), gpio_.line_str(),
                     active_low_ ? " (active low)" : "");
}

void GpiodGenerator::release() {
  if (request_) {
    gpiod_line_request_set_value(request_, offset_, GPIOD_LINE_VALUE_INACTIVE);
    gpiod_line_request_release(request_);
    request_ = nullptr;
  }
  if (chip_) {
    gpiod_chip_close(chip_);
    chip_ = nullptr;
  }
}

void GpiodGenerator::prepare(const PulseTrain& /*train*/) {
  if (request_) return;
  const std::string path = gpio_.chip_path().string();
  std::string why;
  if (!gpio_.valid(&why)) throw TriggerError("gpiod: trigger.gpiod." + why);

  errno = 0;
  chip_ = gpiod_chip_open(path.c_str());
  if (!chip_) throw TriggerError(open_error(path, errno ? errno : ENODEV));

  try {
    if (gpio_.line_name.empty()) {
      ChipInfo info(gpiod_chip_get_info(chip_));
      if (!info)
        throw TriggerError(fmt::format("gpiod: cannot read chip info of {}: {}", path, std::strerror(errno)));
      const size_t lines = gpiod_chip_info_get_num_lines(info.get());
      if (static_cast<size_t>(gpio_.line_offset) >= lines)
        throw TriggerError(fmt::format("gpiod: {} ({}) has {} lines; line {} does not exist", path,
                                       gpiod_chip_info_get_label(info.get()), lines, gpio_.line_offset));
      offset_ = static_cast<unsigned>(gpio_.line_offset);
    } else {
      errno = 0;
      const int offset = gpiod_chip_get_line_offset_from_name(chip_, gpio_.line_name.c_str());
      if (offset < 0)
        throw TriggerError(errno == ENOENT || errno == 0
                               ? fmt::format("gpiod: no line named \"{}\" on {}", gpio_.line_name, path)
                               : fmt::format("gpiod: looking up line \"{}\" on {} failed: {}",
                                             gpio_.line_name, path, std::strerror(errno)));
      offset_ = static_cast<unsigned>(offset);
    }

    // A line held by someone else (another program, a kernel driver) would fail the request with
    // EBUSY; say who holds it.
    LineInfo info(gpiod_chip_get_line_info(chip_, offset_));
    if (info && gpiod_line_info_is_used(info.get())) {
      const char* consumer = gpiod_line_info_get_consumer(info.get());
      throw TriggerError(fmt::format("gpiod: line {} of {} is busy (used by \"{}\")", gpio_.line_str(), path,
                                     consumer ? consumer : "?"));
    }

    LineSettings settings(gpiod_line_settings_new());
    LineConfig line_cfg(gpiod_line_config_new());
    RequestConfig req_cfg(gpiod_request_config_new());
    if (!settings || !line_cfg || !req_cfg) throw TriggerError("gpiod: out of memory");
    if (gpiod_line_settings_set_direction(settings.get(), GPIOD_LINE_DIRECTION_OUTPUT) < 0 ||
        gpiod_line_settings_set_drive(settings.get(), GPIOD_LINE_DRIVE_PUSH_PULL) < 0 ||
        gpiod_line_settings_set_output_value(settings.get(), GPIOD_LINE_VALUE_INACTIVE) < 0)
      throw TriggerError(fmt::format("gpiod: cannot build line settings: {}", std::strerror(errno)));
    gpiod_line_settings_set_active_low(settings.get(), active_low_);
    if (gpiod_line_config_add_line_settings(line_cfg.get(), &offset_, 1, settings.get()) < 0)
      throw TriggerError(fmt::format("gpiod: cannot build line config: {}", std::strerror(errno)));
    gpiod_request_config_set_consumer(req_cfg.get(), "voxcap-trigger");

    errno = 0;
    request_ = gpiod_chip_request_lines(chip_, req_cfg.get(), line_cfg.get());
    if (!request_) {
      const int err = errno;
      throw TriggerError(err == EBUSY ? fmt::format("gpiod: line {} of {} is busy", gpio_.line_str(), path)
                                      : fmt::format("gpiod: requesting line {} of {} as output failed: {}",
                                                    gpio_.line_str(), path, std::strerror(err)));
    }
  } catch (...) {
    release();
    throw;
  }
}

void GpiodGenerator::leading_edge(Pulse& pulse) {
  pulse.t_ns = static_cast<int64_t>(vc::monotonic_ns());
  if (gpiod_line_request_set_value(request_, offset_, GPIOD_LINE_VALUE_ACTIVE) < 0)
    throw TriggerError(
        fmt::format("gpiod: setting line {} failed: {}", gpio_.line_str(), std::strerror(errno)));
}

void GpiodGenerator::trailing_edge() {
  if (gpiod_line_request_set_value(request_, offset_, GPIOD_LINE_VALUE_INACTIVE) < 0)
    throw TriggerError(
        fmt::format("gpiod: clearing line {} failed: {}", gpio_.line_str(), std::strerror(errno)));
}

}  // namespace vc::trigger::detail
