// Where a haptic device's workspace lies in the scene: a uniform scale, a rotation and an offset from
// the device's frame (metres) to the world's, as CHAI3D maps a device into its world.
#pragma once

#include "kiji/types.h"

namespace kiji {

struct WorkspaceMapping {
  double scale = 1.0;                                                // world metres per device metre
  Eigen::Quaterniond rotation = Eigen::Quaterniond::Identity();      // device axes to world axes
  Vec3 offset{0, 0, 0};                                              // the world point of the device's origin

  Vec3 to_world(const Vec3& device_point) const { return offset + scale * (rotation * device_point); }
  Vec3 to_device(const Vec3& world_point) const { return rotation.conjugate() * (world_point - offset) / scale; }
  // A force in the world as the device renders it: the same newtons, turned into the device's axes.
  Vec3 force_to_device(const Vec3& world_force) const { return rotation.conjugate() * world_force; }

  // Throws InputError for a scale that is not a positive finite number, a rotation that is not a
  // unit quaternion, or an offset that is not finite.
  void validate() const;

  // The mapping that makes the device's `workspace` (device metres, device axes) span the box
  // `world` (at least; the tighter axis decides), centred on it, with the device turned by
  // `rotation` (a camera's orientation, so that pushing the pen away from the user moves the
  // pointer away from the viewer). Throws InputError for an empty or non-finite box.
  static WorkspaceMapping fit(const Box3& workspace, const Box3& world,
                              const Eigen::Quaterniond& rotation = Eigen::Quaterniond::Identity());
};

}  // namespace kiji
