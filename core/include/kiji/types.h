// The mesh and vector types shared by every part of Kiji: CGAL's half-edge Surface_mesh and Eigen.
#pragma once

#include <CGAL/Simple_cartesian.h>
#include <CGAL/Surface_mesh.h>
#include <Eigen/Core>
#include <Eigen/Geometry>

#include <array>
#include <cstdint>

namespace kiji {

using Kernel = CGAL::Simple_cartesian<double>;
using Point3 = Kernel::Point_3;
using Mesh = CGAL::Surface_mesh<Point3>;
using Vertex = Mesh::Vertex_index;
using Halfedge = Mesh::Halfedge_index;
using Edge = Mesh::Edge_index;
using Face = Mesh::Face_index;

using Vec2 = Eigen::Vector2d;
using Vec3 = Eigen::Vector3d;
using Box3 = Eigen::AlignedBox3d;

inline Vec3 to_vec(const Point3& p) { return {p.x(), p.y(), p.z()}; }
inline Point3 to_point(const Vec3& v) { return {v.x(), v.y(), v.z()}; }

// True when every component is a finite number (no NaN, no infinity).
template <typename Derived>
bool all_finite(const Eigen::MatrixBase<Derived>& m) {
  return m.allFinite();
}

}  // namespace kiji
