#include "kiji/workspace_mapping.h"

#include "kiji/error.h"

#include <cmath>
#include <sstream>

namespace kiji {

void WorkspaceMapping::validate() const {
  if (!std::isfinite(scale) || scale <= 0) {
    std::ostringstream msg;
    msg << "workspace scale " << scale << " is not a positive number of world metres per device metre";
    throw InputError(msg.str());
  }
  if (!rotation.coeffs().allFinite() || std::abs(rotation.norm() - 1.0) > 1e-6)
    throw InputError("workspace rotation is not a unit quaternion: give a rotation (w, x, y, z) of length 1");
  if (!all_finite(offset)) throw InputError("workspace offset has a coordinate that is not a finite number");
}

WorkspaceMapping WorkspaceMapping::fit(const Box3& workspace, const Box3& world, const Eigen::Quaterniond& rotation) {
  if (workspace.isEmpty() || !all_finite(workspace.min()) || !all_finite(workspace.max()))
    throw InputError("the device reports no usable workspace: cannot fit it to the scene");
  if (world.isEmpty() || !all_finite(world.min()) || !all_finite(world.max()))
    throw InputError("nothing to fit the device's workspace to: the scene has no garment or body");
  WorkspaceMapping m;
  m.rotation = rotation.normalized();
  // The device box turned into world axes: its extent along each world axis.
  const Vec3 device_extent = m.rotation.toRotationMatrix().cwiseAbs() * workspace.sizes();
  const Vec3 world_extent = world.sizes();
  double scale = 0;
  for (int k = 0; k < 3; ++k)
    if (device_extent[k] > 0) scale = std::max(scale, world_extent[k] / device_extent[k]);
  if (!(scale > 0)) scale = 1.0;  // a single point: keep the device's own size
  m.scale = scale;
  m.offset = world.center() - scale * (m.rotation * workspace.center());
  return m;
}

}  // namespace kiji
