// The force models tools share with the haptic loop: the spring to the cloth the hand holds, and the
// push out of the cloth's surface, from a snapshot of the cloth or from the garment itself.
#include "kiji/haptic_force.h"
#include "kiji/pattern.h"

#include <gtest/gtest.h>

using namespace kiji;

namespace {

// The snapshot of every vertex and face of a garment, as the haptic loop would get it.
HapticSnapshot whole(const Garment& g, std::size_t garment = 0) {
  HapticSnapshot s;
  s.garment = garment;
  for (Vertex v : g.mesh().vertices()) {
    s.vertices.push_back(v);
    s.positions.push_back(g.position(v));
  }
  for (Face f : g.mesh().faces()) {
    std::array<int, 3> t{};
    int k = 0;
    for (Vertex v : CGAL::vertices_around_face(g.mesh().halfedge(f), g.mesh())) t[k++] = static_cast<int>(v.idx());
    s.triangles.push_back(t);
  }
  return s;
}

}  // namespace

TEST(HapticSpring, ThePatchPullsTheHandAsOneVertexWouldWithTheWholeStiffness) {
  const Garment g = make_rectangle(1.0, 1.0, 5, 5);  // in the plane z = 0
  const Vec3 pointer(0.5, 0.5, 0.1);
  HapticSpring spring;
  spring.stiffness = 40;
  for (Vertex v : {Vertex(11), Vertex(12), Vertex(13)}) {
    spring.vertices.push_back(v);
    spring.offsets.push_back(g.position(v) - Vec3(0.5, 0.5, 0.0));  // taken with the pen on the cloth
  }
  EXPECT_DOUBLE_EQ(spring.share(), 40.0 / 3);
  // The hand 0.1 m above where it took the cloth: pulled down by the whole spring.
  const Vec3 f = spring.force(g, pointer);
  EXPECT_NEAR(f.x(), 0, 1e-12);
  EXPECT_NEAR(f.y(), 0, 1e-12);
  EXPECT_NEAR(f.z(), -40 * 0.1, 1e-12);
  // The haptic loop's snapshot of the same cloth gives the same force, bit for bit.
  EXPECT_EQ(spring.force(whole(g), pointer), f);
}

TEST(HapticSpring, ClothTheSnapshotOrTheGarmentLacksAddsNothing) {
  const Garment g = make_rectangle(1.0, 1.0, 5, 5);
  const Vec3 pointer(0.5, 0.5, 0.1);
  HapticSpring spring;
  spring.stiffness = 20;
  spring.vertices = {Vertex(12), Vertex(1000)};  // the second is not in this garment
  spring.offsets = {Vec3::Zero(), Vec3::Zero()};
  const Vec3 one = 10.0 * (g.position(Vertex(12)) - pointer);
  EXPECT_EQ(spring.force(g, pointer), one);
  EXPECT_EQ(spring.force(whole(g), pointer), one);
  EXPECT_EQ(spring.force(whole(g, 1), pointer), Vec3::Zero()) << "a snapshot of another garment";
  EXPECT_EQ(HapticSpring{}.force(g, pointer), Vec3::Zero()) << "no cloth held";
}

TEST(HapticPush, PushesThePenOutOfTheClothOnWhicheverSideItIs) {
  const Garment g = make_rectangle(1.0, 1.0, 5, 5);
  const HapticSnapshot snapshot = whole(g);
  const HapticPush push{0.01, 300};
  for (double z : {0.004, -0.004}) {
    const Vec3 pen(0.4, 0.6, z);
    const Vec3 f = push.force(snapshot.nearest(pen), pen);
    EXPECT_NEAR(f.norm(), 300 * (0.01 - 0.004), 1e-12);
    EXPECT_NEAR(f.z(), z > 0 ? f.norm() : -f.norm(), 1e-12) << "along the normal, away from the cloth";
  }
  const Vec3 beyond(0.4, 0.6, 0.02);
  EXPECT_EQ(push.force(snapshot.nearest(beyond), beyond), Vec3::Zero());
  EXPECT_EQ(push.force(SurfaceHit{}, beyond), Vec3::Zero()) << "no cloth under the pen";
}

TEST(HapticModel, TheLoopComputesTheDeclaredModel) {
  const Garment g = make_rectangle(1.0, 1.0, 5, 5);
  const HapticSnapshot snapshot = whole(g);
  ToolEvent e;
  e.position = Vec3(0.4, 0.6, 0.002);
  HapticSpring spring;
  spring.stiffness = 30;
  spring.vertices = {Vertex(12)};
  spring.offsets = {Vec3::Zero()};
  const HapticPush push;
  EXPECT_EQ(haptic_model_force(HapticModel(), snapshot, e).force, Vec3::Zero());
  EXPECT_EQ(haptic_model_force(spring, snapshot, e).force, spring.force(snapshot, e.position));
  EXPECT_EQ(haptic_model_force(push, snapshot, e).force, push.force(snapshot.nearest(e.position), e.position));
  EXPECT_GT(haptic_model_force(push, snapshot, e).force.z(), 0);
}
