// SE(3)/SO(3) helpers: exp/log round trips (including tiny and near-pi angles), composition and
// inverse in the T_a_b naming, rotationAngle.
#include "core/se3.hpp"

#include <cmath>
#include <random>
#include <vector>

#include <gtest/gtest.h>

namespace desslam {
namespace {

constexpr double kPi = 3.14159265358979323846;

Vec3 randomUnit(std::mt19937& rng) {
  std::normal_distribution<double> n(0.0, 1.0);
  Vec3 v(n(rng), n(rng), n(rng));
  return v.normalized();
}

Vec6 randomTwist(std::mt19937& rng, double max_angle) {
  std::uniform_real_distribution<double> angle(0.0, max_angle), trans(-2.0, 2.0);
  Vec6 xi;
  xi.head<3>() = Vec3(trans(rng), trans(rng), trans(rng));
  xi.tail<3>() = randomUnit(rng) * angle(rng);
  return xi;
}

SE3 randomPose(std::mt19937& rng) { return SE3::exp(randomTwist(rng, 3.0)); }

bool isRotation(const Mat3& R, double tol) {
  return (R.transpose() * R - Mat3::Identity()).norm() < tol && std::abs(R.determinant() - 1.0) < tol;
}

// Rotation matrices R and -omega... are compared as matrices: log at pi may return either axis sign.
void expectSameRotation(const Mat3& a, const Mat3& b, double tol) {
  EXPECT_LT((a - b).norm(), tol) << "\n" << a << "\nvs\n" << b;
}

TEST(So3, ExpOfZeroIsIdentityAndLogOfIdentityIsZero) {
  EXPECT_LT((so3Exp(Vec3::Zero()) - Mat3::Identity()).norm(), 1e-15);
  EXPECT_LT(so3Log(Mat3::Identity()).norm(), 1e-15);
}

TEST(So3, ExpMatchesAngleAxis) {
  std::mt19937 rng(1);
  for (int i = 0; i < 100; ++i) {
    const Vec3 axis = randomUnit(rng);
    const double angle = std::uniform_real_distribution<double>(0.0, kPi)(rng);
    const Mat3 expected = Eigen::AngleAxisd(angle, axis).toRotationMatrix();
    expectSameRotation(so3Exp(axis * angle), expected, 1e-12);
  }
}

TEST(So3, LogInvertsExpOverTheRange) {
  std::mt19937 rng(2);
  for (int i = 0; i < 200; ++i) {
    const Vec3 omega = randomUnit(rng) * std::uniform_real_distribution<double>(1e-3, kPi - 1e-3)(rng);
    const Mat3 R = so3Exp(omega);
    ASSERT_TRUE(isRotation(R, 1e-12));
    EXPECT_LT((so3Log(R) - omega).norm(), 1e-9) << "omega " << omega.transpose();
  }
}

TEST(So3, SmallAnglesKeepTheirPrecision) {
  std::mt19937 rng(3);
  for (double angle : {1e-3, 1e-6, 1e-8, 1e-10, 1e-12, 1e-15}) {
    const Vec3 omega = randomUnit(rng) * angle;
    const Mat3 R = so3Exp(omega);
    EXPECT_TRUE(isRotation(R, 1e-12)) << "angle " << angle;
    const Vec3 back = so3Log(R);
    // Absolute error far below the angle itself: the direction of a tiny rotation survives.
    EXPECT_LT((back - omega).norm(), 1e-3 * angle + 1e-17) << "angle " << angle;
    EXPECT_TRUE(back.allFinite());
  }
}

TEST(So3, NearPiAnglesRoundTripAsRotations) {
  std::mt19937 rng(4);
  for (double delta : {1e-3, 1e-6, 1e-9, 0.0}) {
    for (int i = 0; i < 20; ++i) {
      const Vec3 axis = randomUnit(rng);
      const double angle = kPi - delta;
      const Vec3 omega = axis * angle;
      const Mat3 R = so3Exp(omega);
      const Vec3 back = so3Log(R);
      ASSERT_TRUE(back.allFinite()) << "delta " << delta;
      EXPECT_NEAR(back.norm(), angle, 1e-7) << "delta " << delta;
      // At (or next to) pi, omega and -omega are (nearly) the same rotation: compare matrices,
      // and the axis up to sign.
      expectSameRotation(so3Exp(back), R, 1e-7);
      EXPECT_NEAR(std::abs(back.normalized().dot(axis)), 1.0, 1e-7) << "delta " << delta;
    }
  }
}

TEST(So3, SkewIsTheCrossProduct) {
  const Vec3 a(0.3, -1.2, 2.5), b(-0.7, 0.4, 1.1);
  EXPECT_LT((skew(a) * b - a.cross(b)).norm(), 1e-15);
}

TEST(Se3, ExpLogRoundTrip) {
  std::mt19937 rng(5);
  for (int i = 0; i < 200; ++i) {
    const Vec6 xi = randomTwist(rng, kPi - 1e-3);
    const SE3 T = SE3::exp(xi);
    ASSERT_TRUE(isRotation(T.rotation(), 1e-12));
    EXPECT_LT((T.log() - xi).norm(), 1e-8) << "xi " << xi.transpose();
  }
}

TEST(Se3, ExpOfPureTranslationTranslates) {
  Vec6 xi = Vec6::Zero();
  xi.head<3>() = Vec3(0.5, -1.0, 2.0);
  const SE3 T = SE3::exp(xi);
  EXPECT_LT((T.translation() - Vec3(0.5, -1.0, 2.0)).norm(), 1e-15);
  EXPECT_LT(T.rotationAngle(), 1e-15);
}

TEST(Se3, SmallTwistsRoundTrip) {
  std::mt19937 rng(6);
  for (double angle : {1e-4, 1e-7, 1e-9, 1e-12}) {
    Vec6 xi;
    xi.head<3>() = Vec3(0.1, -0.2, 0.3);
    xi.tail<3>() = randomUnit(rng) * angle;
    EXPECT_LT((SE3::exp(xi).log() - xi).norm(), 1e-10) << "angle " << angle;
  }
}

TEST(Se3, CompositionFollowsTheFrameNames) {
  std::mt19937 rng(7);
  std::uniform_real_distribution<double> coord(-3.0, 3.0);
  for (int i = 0; i < 100; ++i) {
    const SE3 T_a_b = randomPose(rng), T_b_c = randomPose(rng);
    const Vec3 p_c(coord(rng), coord(rng), coord(rng));
    const SE3 T_a_c = T_a_b * T_b_c;
    EXPECT_LT(((T_a_c * p_c) - (T_a_b * (T_b_c * p_c))).norm(), 1e-12);
    // The same as 4x4 matrices.
    EXPECT_LT((T_a_c.matrix() - T_a_b.matrix() * T_b_c.matrix()).norm(), 1e-12);
  }
}

TEST(Se3, InverseUndoes) {
  std::mt19937 rng(8);
  for (int i = 0; i < 100; ++i) {
    const SE3 T_w_c = randomPose(rng);
    const SE3 T_c_w = T_w_c.inverse();
    const Vec3 p_c(0.4, -0.3, 1.7);
    EXPECT_LT((T_c_w * (T_w_c * p_c) - p_c).norm(), 1e-12);
    EXPECT_LT((T_w_c * T_c_w).log().norm(), 1e-12);
    EXPECT_LT((T_c_w * T_w_c).log().norm(), 1e-12);
    EXPECT_LT((T_c_w.matrix() - T_w_c.matrix().inverse()).norm(), 1e-12);
  }
}

TEST(Se3, IdentityAndMatrixConversion) {
  EXPECT_LT((SE3::identity().matrix() - Mat4::Identity()).norm(), 1e-15);
  std::mt19937 rng(9);
  const SE3 T = randomPose(rng);
  const SE3 back = SE3::fromMatrix(T.matrix());
  EXPECT_LT((back.matrix() - T.matrix()).norm(), 1e-12);
  const Mat4 M = T.matrix();
  EXPECT_EQ(M(3, 0), 0.0);
  EXPECT_EQ(M(3, 1), 0.0);
  EXPECT_EQ(M(3, 2), 0.0);
  EXPECT_EQ(M(3, 3), 1.0);
}

TEST(Se3, RotationAngleIsTheAngleInZeroToPi) {
  std::mt19937 rng(10);
  for (double angle : {0.0, 1e-12, 1e-8, 1e-3, 0.5, 1.5, 3.0, kPi - 1e-6, kPi}) {
    const Vec3 axis = randomUnit(rng);
    const SE3 T(so3Exp(axis * angle), Vec3(1, 2, 3));
    EXPECT_NEAR(T.rotationAngle(), angle, 1e-9 + 1e-6 * angle) << "angle " << angle;
    EXPECT_NEAR(T.inverse().rotationAngle(), angle, 1e-9 + 1e-6 * angle) << "angle " << angle;
  }
  // A rotation by more than pi is the same as the opposite rotation by less.
  const SE3 T(so3Exp(Vec3(0, 0, 1.5 * kPi)), Vec3::Zero());
  EXPECT_NEAR(T.rotationAngle(), 0.5 * kPi, 1e-9);
  // The quaternion sign (q and -q are the same rotation) does not matter.
  const Quat q(Eigen::AngleAxisd(0.7, Vec3::UnitX()));
  const SE3 a(q, Vec3::Zero()), b(Quat(-q.w(), -q.x(), -q.y(), -q.z()), Vec3::Zero());
  EXPECT_NEAR(a.rotationAngle(), 0.7, 1e-12);
  EXPECT_NEAR(b.rotationAngle(), 0.7, 1e-12);
}

TEST(Se3, RelativePoseAngleIsTheAngleBetweenOrientations) {
  const SE3 T_w_a(so3Exp(Vec3(0, 0, 0.3)), Vec3(1, 0, 0));
  const SE3 T_w_b(so3Exp(Vec3(0, 0, 0.8)), Vec3(0, 1, 0));
  const SE3 T_a_b = T_w_a.inverse() * T_w_b;
  EXPECT_NEAR(T_a_b.rotationAngle(), 0.5, 1e-12);
  // b's origin seen from a.
  EXPECT_LT((T_a_b.translation() - T_w_a.inverse() * Vec3(0, 1, 0)).norm(), 1e-12);
}

TEST(Se3, ConstructorNormalisesTheQuaternion) {
  const SE3 T(Quat(2.0, 0.0, 0.0, 0.0), Vec3::Zero());
  EXPECT_NEAR(T.quaternion().norm(), 1.0, 1e-15);
  EXPECT_LT((T * Vec3(1, 2, 3) - Vec3(1, 2, 3)).norm(), 1e-15);
}

}  // namespace
}  // namespace desslam
