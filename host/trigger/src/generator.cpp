// The one place a trigger backend is chosen by name.
#include "voxcap/trigger/generator.hpp"

#include "backends.hpp"

namespace vc::trigger {

std::unique_ptr<Generator> make_generator(const config::TriggerOptions& options) {
  switch (options.backend) {
    case config::TriggerBackend::Udp:
      return std::make_unique<detail::UdpGenerator>(options);
    case config::TriggerBackend::Gpiod:
      return std::make_unique<detail::GpiodGenerator>(options);
    case config::TriggerBackend::Ftdi:
      return std::make_unique<detail::FtdiGenerator>(options);
  }
  throw TriggerError("unknown trigger backend");
}

}  // namespace vc::trigger
