// Collision queries against a body, with Bullet's trees as the broadphase and exact
// point-triangle tests in Kiji's own code. Bullet stays behind this header.
#pragma once

#include "kiji/body.h"

#include <memory>
#include <vector>

namespace kiji {

struct BodyContact {
  bool hit = false;
  std::size_t triangle = 0;
  Vec3 point;        // closest point on the body
  Vec3 normal;       // outward unit normal of the body at that point
  double distance = 0;  // signed distance of the query point along `normal` (negative = inside)
};

class BodyCollider {
 public:
  explicit BodyCollider(const Body& body);
  ~BodyCollider();
  BodyCollider(const BodyCollider&) = delete;
  BodyCollider& operator=(const BodyCollider&) = delete;

  const Body& body() const { return *body_; }

  // Whether triangle t of the body has no area (three points on a line): such a triangle takes no
  // part in collisions.
  static bool degenerate(const Body& body, std::size_t t);

  // Triangles whose bounding boxes overlap the box (Bullet's tree); never a degenerate one.
  void triangles_in_box(const Box3& box, std::vector<int>& out) const;
  // The closest body point to p within `radius`; hit = false if none is that close.
  BodyContact closest(const Vec3& p, double radius) const;
  // The first body triangle crossed by the segment a -> b; hit = false if none.
  BodyContact first_crossing(const Vec3& a, const Vec3& b) const;
  // Whether p is inside the body's volume: the body's faces crossed by three rays from p, each
  // counted +1 where the ray leaves through it and -1 where it enters, sum to 1 or more (2 where
  // two parts overlap) on all three, or on none; where the rays disagree (an open surface), the
  // winding number of the whole surface around p is over a half. Unlike the side of the closest
  // face, it holds on a game model's sheets of no thickness (a fin counts +1 and -1), its faces
  // turned inwards or buried in the volume, and beside a hole.
  bool inside(const Vec3& p) const;

 private:
  const Body* body_;
  struct Impl;
  std::unique_ptr<Impl> impl_;
};

}  // namespace kiji
