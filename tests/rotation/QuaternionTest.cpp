// Quaternion algebra checked against the axis–angle rotation matrix (Irazábal 2017 eq. 5.28) and identities.
#define BOOST_TEST_MODULE rotation_quaternion
#include <boost/test/unit_test.hpp>

#include <cmath>
#include <stdexcept>

#include "kernels/Quaternion.hpp"
#include "kernels/RotationIntegrators.hpp"

using namespace railcosim::kernels;

namespace {

// Round-off bound for a handful of double operations on O(1) values.
constexpr double kRoundOff = 1e-13;

// Rotation by the axis–angle matrix of eq. 5.28: an oracle that shares no code with the quaternion path.
Vec3 rotateByMatrix(const Vec3& u, double angle, const Vec3& v) {
  const double c = std::cos(angle);
  const double s = std::sin(angle);
  const double r[3][3] = {{c + u.x * u.x * (1 - c), u.x * u.y * (1 - c) - u.z * s, u.x * u.z * (1 - c) + u.y * s},
                          {u.y * u.x * (1 - c) + u.z * s, c + u.y * u.y * (1 - c), u.y * u.z * (1 - c) - u.x * s},
                          {u.z * u.x * (1 - c) - u.y * s, u.z * u.y * (1 - c) + u.x * s, c + u.z * u.z * (1 - c)}};
  return Vec3{r[0][0] * v.x + r[0][1] * v.y + r[0][2] * v.z, r[1][0] * v.x + r[1][1] * v.y + r[1][2] * v.z,
              r[2][0] * v.x + r[2][1] * v.y + r[2][2] * v.z};
}

double distance(const Vec3& a, const Vec3& b) { return norm(a - b); }

double distance(const Quaternion& a, const Quaternion& b) {
  return std::sqrt((a.w - b.w) * (a.w - b.w) + (a.x - b.x) * (a.x - b.x) + (a.y - b.y) * (a.y - b.y) +
                   (a.z - b.z) * (a.z - b.z));
}

const Vec3 kAxis = Vec3{1.0, -2.0, 0.5} / norm(Vec3{1.0, -2.0, 0.5});

} // namespace

BOOST_AUTO_TEST_CASE(rotation_matches_axis_angle_matrix) {
  const Vec3 v{0.3, 1.7, -0.9};
  for (double angle : {0.0, 0.1, 1.0, 2.5, 3.14159, 5.0}) {
    const Quaternion q = quaternionFromAxisAngle(kAxis, angle);
    BOOST_TEST(std::abs(norm(q) - 1.0) < kRoundOff);
    BOOST_TEST(distance(rotate(q, v), rotateByMatrix(kAxis, angle, v)) < kRoundOff);
    BOOST_TEST(distance(rotateInverse(q, rotate(q, v)), v) < kRoundOff);
  }
}

BOOST_AUTO_TEST_CASE(product_composes_rotations_and_conjugate_inverts) {
  const Quaternion p = quaternionFromAxisAngle(kAxis, 0.7);
  const Quaternion q = quaternionFromAxisAngle(Vec3{0.0, 0.0, 1.0}, -1.2);
  const Vec3 v{-0.4, 0.2, 2.0};
  // (p q) v (p q)* = p (q v q*) p*: left multiplication applies q first.
  BOOST_TEST(distance(rotate(p * q, v), rotate(p, rotate(q, v))) < kRoundOff);
  BOOST_TEST(distance(p * conjugate(p), identityQuaternion()) < kRoundOff);
  // Non-commutative for non-parallel axes (eq. 5.34): the difference is O(1), far above round-off.
  BOOST_TEST(distance(p * q, q * p) > 0.1);
}

BOOST_AUTO_TEST_CASE(increments_about_one_axis_add_up) {
  // n increments of angle a about a fixed axis equal one rotation by n a (the basis of eq. 5.39).
  const Vec3 omega = 3.0 * kAxis;
  const double timeStep = 1e-3;
  Quaternion q = identityQuaternion();
  for (int i = 0; i < 1000; ++i) q = incrementalRotation(omega, timeStep) * q;
  // 1000 products accumulate ~1000 ulps at most: 1e-12.
  BOOST_TEST(distance(q, quaternionFromAxisAngle(kAxis, 3.0)) < 1e-12);
}

BOOST_AUTO_TEST_CASE(small_angles_are_continuous_and_rotation_vector_round_trips) {
  // Across the series/trig switch at 1e-4 rad the two branches agree to round-off.
  for (double angle : {0.0, 1e-12, 0.99e-4, 1.01e-4, 1e-2, 2.0, 3.1}) {
    const Quaternion q = rotationQuaternion(angle * kAxis);
    BOOST_TEST(std::abs(norm(q) - 1.0) < kRoundOff);
    BOOST_TEST(std::abs(q.w - std::cos(0.5 * angle)) < kRoundOff);
    BOOST_TEST(distance(vectorPart(q), std::sin(0.5 * angle) * kAxis) < kRoundOff);
    BOOST_TEST(distance(rotationVector(q), angle * kAxis) < 1e-12);
  }
  // q and −q are the same rotation: rotationVector picks the angle in [0, π].
  const Quaternion q = quaternionFromAxisAngle(kAxis, 0.5);
  const Quaternion minusQ{-q.w, -q.x, -q.y, -q.z};
  BOOST_TEST(distance(rotationVector(minusQ), 0.5 * kAxis) < 1e-12);
}

BOOST_AUTO_TEST_CASE(rotated_diagonal_tensor_matches_r_a_rt) {
  // R diag(d) Rᵀ v built from the matrix oracle (eq. 5.38 ≡ R A Rᵀ).
  const double angle = 0.9;
  const Quaternion q = quaternionFromAxisAngle(kAxis, angle);
  const Vec3 diagonal{2.0, 3.0, 0.5};
  const Vec3 v{1.0, -1.0, 0.25};
  const Vec3 body = rotateByMatrix(kAxis, -angle, v);
  const Vec3 expected =
      rotateByMatrix(kAxis, angle, Vec3{diagonal.x * body.x, diagonal.y * body.y, diagonal.z * body.z});
  BOOST_TEST(distance(applyRotatedDiagonal(q, diagonal, v), expected) < kRoundOff);
}

BOOST_AUTO_TEST_CASE(scheme_names_round_trip_and_bad_input_is_reported) {
  for (RotationScheme scheme : {RotationScheme::zhaoVanWachem, RotationScheme::rungeKutta4, RotationScheme::direct}) {
    BOOST_TEST((rotationSchemeFromName(rotationSchemeName(scheme)) == scheme));
  }
  BOOST_CHECK_THROW(rotationSchemeFromName("verlet"), std::invalid_argument);
  BOOST_CHECK_THROW(validatePrincipalInertia(Vec3{1.0, 0.0, 1.0}, "test"), std::invalid_argument);
  BOOST_CHECK_THROW(validatePrincipalInertia(Vec3{1.0, 1.0, NAN}, "test"), std::invalid_argument);
  BOOST_CHECK_NO_THROW(validatePrincipalInertia(Vec3{1.0, 2.0, 3.0}, "test"));
}
