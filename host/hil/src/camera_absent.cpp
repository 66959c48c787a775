// The alignment test's cameras in a host-only build (VOXCAP_PARTS=host): no libcamera, so no camera
// library; every open says which build has them.
#include "voxcap/hil/camera.hpp"

namespace vc::hil {

bool cameras_built_in() {
  return false;
}

std::unique_ptr<TriggeredCamera> open_camera(const CameraSpec& /*spec*/) {
  throw CamerasUnavailable(
      "this voxcap has no camera backends: it was built without the edge part (VOXCAP_PARTS=host, no "
      "libcamera); the alignment test needs a voxcap built with the edge part "
      "(-DVOXCAP_PARTS=\"edge;host\")");
}

}  // namespace vc::hil
