// The device's workspace placed in the scene: what the pen reaches, and which way a push goes.
#include "kiji/workspace_mapping.h"

#include "support/test_errors.h"

#include <gtest/gtest.h>

#include <cmath>

using namespace kiji;

namespace {

// An Omni's usable workspace, metres, device axes (Y up, +Z towards the user).
const Box3 kOmni(Vec3(-0.08, -0.06, -0.035), Vec3(0.08, 0.06, 0.035));

bool reaches(const WorkspaceMapping& m, const Box3& device, const Vec3& world_point) {
  const Vec3 d = m.to_device(world_point);
  return (d.array() >= device.min().array() - 1e-12).all() && (d.array() <= device.max().array() + 1e-12).all();
}

}  // namespace

TEST(WorkspaceMapping, FittedToABodyThePenReachesAllOfIt) {
  const Box3 body(Vec3(-0.4, 0.0, -0.15), Vec3(0.4, 1.66, 0.15));
  const WorkspaceMapping m = WorkspaceMapping::fit(kOmni, body);
  for (int corner = 0; corner < 8; ++corner)
    EXPECT_TRUE(reaches(m, kOmni, body.corner(static_cast<Box3::CornerType>(corner)))) << corner;
  // The tightest axis decides: 1.66 m of height over 0.12 m of the device's.
  EXPECT_NEAR(m.scale, 1.66 / 0.12, 1e-12);
  EXPECT_TRUE(m.to_world(kOmni.center()).isApprox(body.center())) << "the device's centre is the body's";
  // Round trip, and the device's axes are the world's with no rotation.
  const Vec3 p(0.01, -0.02, 0.03);
  EXPECT_TRUE(m.to_device(m.to_world(p)).isApprox(p));
  EXPECT_GT((m.to_world(Vec3(0, 0.01, 0)) - m.to_world(Vec3::Zero())).y(), 0) << "pen up is world up";
}

TEST(WorkspaceMapping, TurnedWithTheCameraAPushAwayGoesAwayFromTheViewer) {
  // A camera on the body's right (+X) looking at it along -X: turned 90 degrees about +Y.
  const Eigen::Quaterniond camera(Eigen::AngleAxisd(M_PI / 2, Vec3::UnitY()));
  const Box3 garment(Vec3(-0.3, 0.8, -0.2), Vec3(0.3, 1.4, 0.2));
  const WorkspaceMapping m = WorkspaceMapping::fit(kOmni, garment, camera);
  for (int corner = 0; corner < 8; ++corner)
    EXPECT_TRUE(reaches(m, kOmni, garment.corner(static_cast<Box3::CornerType>(corner)))) << corner;
  // The pen pushed away from the user (device -Z) moves the pointer away from the camera (world -X).
  const Vec3 push = m.to_world(Vec3(0, 0, -0.01)) - m.to_world(Vec3::Zero());
  EXPECT_LT(push.x(), 0);
  EXPECT_NEAR(push.y(), 0, 1e-12);
  // A force keeps its size and turns back into the device's axes.
  const Vec3 f = m.force_to_device(Vec3(-1, 0, 0));
  EXPECT_TRUE(f.isApprox(Vec3(0, 0, -1), 1e-12)) << f.transpose();
}

TEST(WorkspaceMapping, NothingToFitToIsAClearError) {
  EXPECT_NE(test::input_error([] { WorkspaceMapping::fit(kOmni, Box3()); }).find("nothing to fit"), std::string::npos);
  EXPECT_NE(test::input_error([] { WorkspaceMapping::fit(Box3(), Box3(Vec3::Zero(), Vec3::Ones())); })
                .find("no usable workspace"),
            std::string::npos);
  WorkspaceMapping m;
  m.scale = 0;
  EXPECT_NE(test::input_error([&] { m.validate(); }).find("scale"), std::string::npos);
  m = WorkspaceMapping{};
  m.offset.x() = std::nan("");
  EXPECT_NE(test::input_error([&] { m.validate(); }).find("offset"), std::string::npos);
}
