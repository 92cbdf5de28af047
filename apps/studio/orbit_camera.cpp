#include "orbit_camera.h"

#include <algorithm>
#include <cmath>

namespace kiji::studio {

namespace {
constexpr double kMaxPitch = 1.55;  // just short of straight down or up, where yaw turns degenerate
}

Vec3 OrbitCamera::forward() const {
  return Vec3(-std::sin(yaw) * std::cos(pitch), -std::sin(pitch), -std::cos(yaw) * std::cos(pitch));
}

Vec3 OrbitCamera::eye() const { return target - distance * forward(); }

Vec3 OrbitCamera::right() const { return forward().cross(Vec3::UnitY()).normalized(); }

Vec3 OrbitCamera::up() const { return right().cross(forward()); }

Eigen::Quaterniond OrbitCamera::orientation() const {
  Eigen::Matrix3d axes;
  axes.col(0) = right();
  axes.col(1) = up();
  axes.col(2) = -forward();
  return Eigen::Quaterniond(axes).normalized();
}

void OrbitCamera::orbit(double d_yaw, double d_pitch) {
  yaw = std::remainder(yaw + d_yaw, 2 * M_PI);
  pitch = std::clamp(pitch + d_pitch, -kMaxPitch, kMaxPitch);
}

void OrbitCamera::pan(double dx, double dy) {
  const double height = 2 * distance * std::tan(fov_degrees * M_PI / 360);
  target += height * (dx * right() + dy * up());
}

void OrbitCamera::zoom(double factor) { distance = std::clamp(distance * factor, 1e-3, 1e4); }

void OrbitCamera::frame(const Box3& box, double aspect) {
  if (box.isEmpty() || !all_finite(box.min()) || !all_finite(box.max())) return;
  target = box.center();
  const double radius = std::max(0.5 * box.sizes().norm(), 0.05);
  const double half_fov = fov_degrees * M_PI / 360;
  const double half_fov_x = std::atan(std::tan(half_fov) * std::max(aspect, 1e-3));
  distance = 1.1 * radius / std::sin(std::min(half_fov, half_fov_x));
}

Eigen::Matrix4f OrbitCamera::view() const {
  const Vec3 f = forward(), r = right(), u = up(), e = eye();
  Eigen::Matrix4d m = Eigen::Matrix4d::Identity();
  m.block<1, 3>(0, 0) = r.transpose();
  m.block<1, 3>(1, 0) = u.transpose();
  m.block<1, 3>(2, 0) = -f.transpose();
  m(0, 3) = -r.dot(e);
  m(1, 3) = -u.dot(e);
  m(2, 3) = f.dot(e);
  return m.cast<float>();
}

double OrbitCamera::near_plane() const { return std::max(distance * 0.01, 1e-3); }
double OrbitCamera::far_plane() const { return distance * 100 + 10; }

Eigen::Matrix4f OrbitCamera::projection(double aspect) const {
  const double n = near_plane(), f = far_plane();
  const double t = 1.0 / std::tan(fov_degrees * M_PI / 360);
  Eigen::Matrix4d p = Eigen::Matrix4d::Zero();
  p(0, 0) = t / std::max(aspect, 1e-6);
  p(1, 1) = t;
  p(2, 2) = (f + n) / (n - f);
  p(2, 3) = 2 * f * n / (n - f);
  p(3, 2) = -1;
  return p.cast<float>();
}

Vec3 OrbitCamera::ray(double x, double y, double aspect) const {
  const double t = std::tan(fov_degrees * M_PI / 360);
  return (forward() + x * t * aspect * right() + y * t * up()).normalized();
}

}  // namespace kiji::studio
