#include "cfuse/kernel/so3.h"

#include <Eigen/Geometry>
#include <catch2/catch.hpp>
#include <random>

#include "cfuse/kernel/jet.h"
#include "cfuse/kernel/rigid3.h"

namespace cfuse {
namespace {

Eigen::Matrix3d RandomRotation(std::mt19937& rng) {
  std::normal_distribution<double> n(0, 1);
  Eigen::Quaterniond q(n(rng), n(rng), n(rng), n(rng));
  return q.normalized().toRotationMatrix();
}

TEST_CASE("so3: Exp matches Eigen's angle-axis over the whole range", "[kernel]") {
  std::mt19937 rng(1);
  std::uniform_real_distribution<double> u(-1, 1), angle(0, M_PI);
  for (int i = 0; i < 200; ++i) {
    const Eigen::Vector3d axis = Eigen::Vector3d(u(rng), u(rng), u(rng)).normalized();
    const double theta = i == 0 ? 0.0 : i == 1 ? 1e-9 : angle(rng);
    const Eigen::Matrix3d R = ExpSO3<double>(axis * theta);
    CHECK((R - Eigen::AngleAxisd(theta, axis).toRotationMatrix()).norm() < 1e-12);
    CHECK((R.transpose() * R - Eigen::Matrix3d::Identity()).norm() < 1e-12);
  }
}

TEST_CASE("so3: InverseRightJacobianSO3 inverts the right Jacobian up to near a full turn",
          "[kernel]") {
  std::mt19937 rng(7);
  std::uniform_real_distribution<double> u(-1, 1), angle(0, 1.9 * M_PI);
  for (int i = 0; i < 300; ++i) {
    const Eigen::Vector3d axis = Eigen::Vector3d(u(rng), u(rng), u(rng)).normalized();
    const double theta = i == 0 ? 0.0 : i == 1 ? 1e-7 : i == 2 ? M_PI : angle(rng);
    const Eigen::Vector3d w = axis * theta;
    const Eigen::Matrix3d product = InverseRightJacobianSO3(w) * RightJacobianSO3(w);
    INFO("angle " << theta);
    CHECK((product - Eigen::Matrix3d::Identity()).norm() < 1e-10);
  }
}

TEST_CASE("so3: LogSO3 of a quaternion inverts Exp, on either sign of the quaternion", "[kernel]") {
  std::mt19937 rng(8);
  std::uniform_real_distribution<double> u(-1, 1), angle(0, M_PI);
  for (int i = 0; i < 300; ++i) {
    const Eigen::Vector3d axis = Eigen::Vector3d(u(rng), u(rng), u(rng)).normalized();
    const double theta = i == 0 ? 0.0 : i == 1 ? 1e-10 : i == 2 ? M_PI - 1e-9 : angle(rng);
    const Eigen::Quaterniond q(Eigen::AngleAxisd(theta, axis));
    const Eigen::Quaterniond minus_q(-q.w(), -q.x(), -q.y(), -q.z());
    INFO("angle " << theta);
    CHECK((LogSO3(q) - theta * axis).norm() < 1e-12);
    CHECK((LogSO3(minus_q) - theta * axis).norm() < 1e-12);
    CHECK((ExpSO3<double>(LogSO3(q)) - q.toRotationMatrix()).norm() < 1e-12);
  }
}

TEST_CASE("so3: the autodiff derivative of Exp at zero is the hat operator", "[kernel]") {
  Vector3<Jet> w;
  for (int i = 0; i < 3; ++i) w[i] = Jet(0.0, kJetMaxDerivatives, i);
  const Matrix3<Jet> R = ExpSO3<Jet>(w);
  for (int k = 0; k < 3; ++k) {
    const Eigen::Matrix3d expected = Hat<double>(Eigen::Vector3d::Unit(k));
    for (int r = 0; r < 3; ++r)
      for (int c = 0; c < 3; ++c)
        CHECK(R(r, c).derivatives()[k] == Approx(expected(r, c)).margin(1e-15));
  }
}

TEST_CASE("so3: RotationToQuaternion agrees with Eigen, including near half a turn", "[kernel]") {
  std::mt19937 rng(2);
  for (int i = 0; i < 500; ++i) {
    Eigen::Matrix3d R = RandomRotation(rng);
    if (i % 5 == 0)
      R = Eigen::AngleAxisd(M_PI - 1e-7 * (i % 3), Eigen::Vector3d(1, 2, 3).normalized())
              .toRotationMatrix();
    const Vector4<double> q = RotationToQuaternion<double>(R);
    const Eigen::Quaterniond e(R);
    // q and -q are the same rotation.
    const double sign = q[0] * e.w() + q.tail<3>().dot(e.vec()) < 0 ? -1 : 1;
    CHECK(std::abs(q[0] - sign * e.w()) < 1e-9);
    CHECK((q.tail<3>() - sign * e.vec()).norm() < 1e-9);
  }
}

TEST_CASE("so3: RotationError vanishes only at the identity", "[kernel]") {
  CHECK(RotationError<double>(Eigen::Matrix3d::Identity()).norm() == 0.0);
  // At half a turn the skew part of R vanishes; the rotation error must not.
  const Eigen::Matrix3d half = Eigen::AngleAxisd(M_PI, Eigen::Vector3d::UnitZ()).toRotationMatrix();
  CHECK(RotationError<double>(half).norm() == Approx(2.0));
  // Small rotations: the error is the rotation vector to first order.
  const Eigen::Vector3d w(1e-4, -2e-4, 3e-4);
  CHECK((RotationError<double>(ExpSO3<double>(w)) - w).norm() < 1e-10);
}

TEST_CASE("so3: roll-pitch-yaw follows URDF (Rz * Ry * Rx)", "[kernel]") {
  const double r = 0.3, p = -0.7, y = 1.9;
  const Eigen::Matrix3d expected = (Eigen::AngleAxisd(y, Eigen::Vector3d::UnitZ()) *
                                    Eigen::AngleAxisd(p, Eigen::Vector3d::UnitY()) *
                                    Eigen::AngleAxisd(r, Eigen::Vector3d::UnitX()))
                                       .toRotationMatrix();
  CHECK((RotationFromRpy<double>(r, p, y) - expected).norm() < 1e-14);
}

TEST_CASE("so3: OrthonormalComplement gives a right-handed orthonormal basis", "[kernel]") {
  std::mt19937 rng(3);
  std::normal_distribution<double> n(0, 1);
  for (int i = 0; i < 100; ++i) {
    Eigen::Vector3d a(n(rng), n(rng), n(rng));
    if (i < 3) a = Eigen::Vector3d::Unit(i);
    a.normalize();
    Eigen::Vector3d e1, e2;
    OrthonormalComplement<double>(a, &e1, &e2);
    CHECK(std::abs(e1.dot(a)) < 1e-14);
    CHECK(std::abs(e2.dot(a)) < 1e-14);
    CHECK(std::abs(e1.dot(e2)) < 1e-14);
    CHECK((e1.cross(e2) - a).norm() < 1e-14);
  }
}

TEST_CASE("so3: OrthonormalComplement is smooth at the directions models are full of", "[kernel]") {
  const double h = 1e-7;
  for (const Eigen::Vector3d& d :
       {Eigen::Vector3d(1, 0, 0), Eigen::Vector3d(0, 1, 0), Eigen::Vector3d(0, 0, 1),
        Eigen::Vector3d(1, 1, 0), Eigen::Vector3d(0, 1, 1), Eigen::Vector3d(1, 0, 1),
        Eigen::Vector3d(1, 1, 1), Eigen::Vector3d(-1, 0, 1)}) {
    for (int k = 0; k < 3; ++k) {
      const Eigen::Vector3d n = d.normalized();
      const Eigen::Vector3d m = (d + h * Eigen::Vector3d::Unit(k)).normalized();
      Eigen::Vector3d a1, a2, b1, b2;
      OrthonormalComplement<double>(n, &a1, &a2);
      OrthonormalComplement<double>(m, &b1, &b2);
      CHECK((a1 - b1).norm() < 10 * h);
      CHECK((a2 - b2).norm() < 10 * h);
    }
  }
}

TEST_CASE("rigid3: composition, inverse and the x_a = R x_b + t convention", "[kernel]") {
  std::mt19937 rng(4);
  const Rigid3d a_from_b(Eigen::Quaterniond(RandomRotation(rng)), Eigen::Vector3d(1, 2, 3));
  const Rigid3d b_from_c(Eigen::Quaterniond(RandomRotation(rng)), Eigen::Vector3d(-1, 0.5, 2));
  const Eigen::Vector3d x_c(0.3, -0.2, 0.9);
  CHECK(((a_from_b * b_from_c) * x_c - a_from_b * (b_from_c * x_c)).norm() < 1e-12);
  CHECK((a_from_b.Inverse() * (a_from_b * x_c) - x_c).norm() < 1e-12);
  const Rigid3d p = Rigid3d::FromXyzRpy({1, 0, 0}, {0, 0, M_PI / 2});
  CHECK((p * Eigen::Vector3d(1, 0, 0) - Eigen::Vector3d(1, 1, 0)).norm() < 1e-12);
}

}  // namespace
}  // namespace cfuse
