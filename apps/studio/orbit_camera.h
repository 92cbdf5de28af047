// The viewport's camera: it orbits a target (yaw and pitch), pans it, zooms, frames a box, and
// turns a pixel into a ray into the scene.
#pragma once

#include "kiji/types.h"

namespace kiji::studio {

class OrbitCamera {
 public:
  Vec3 target{0, 1, 0};
  double yaw = 0;       // radians about +Y; 0 looks along -Z (from the body's front)
  double pitch = 0.15;  // radians above the horizon
  double distance = 3;  // metres from the target
  double fov_degrees = 35;

  Vec3 eye() const;
  Vec3 forward() const;  // unit, from the eye to the target
  Vec3 right() const;
  Vec3 up() const;
  // The camera's orientation: its axes (right, up, -forward) in the world.
  Eigen::Quaterniond orientation() const;

  void orbit(double d_yaw, double d_pitch);
  // Moves the target across the view by a fraction of the view's height (dx right, dy up).
  void pan(double dx, double dy);
  // Brings the eye nearer (factor < 1) or farther (> 1).
  void zoom(double factor);
  // The whole box in view, from the current direction.
  void frame(const Box3& box, double aspect);

  Eigen::Matrix4f view() const;
  Eigen::Matrix4f projection(double aspect) const;
  // The ray from the eye through a point of the view, given in normalised coordinates
  // (x, y in [-1, 1], y up).
  Vec3 ray(double x, double y, double aspect) const;
  double near_plane() const;
  double far_plane() const;
};

}  // namespace kiji::studio
