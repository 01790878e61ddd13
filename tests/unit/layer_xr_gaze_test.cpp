// SPLITVK_GAZE=openxr's geometry (layer/xr/xr_gaze.h): an eye's orientation in the head from a frame's
// projection view, and where a gaze located in the head falls in each eye's image.

#include "xr/xr_gaze.h"

#include <cmath>

#include <gtest/gtest.h>

namespace splitvk::xr {
namespace {

using split::kGazeOne;

constexpr double kQuarterPi = 0.785398163397448;

// A turn of `angle` radians about +y: positive turns -z (ahead) towards -x (left).
XrQuaternionf yaw(double angle) {
    return {0, static_cast<float>(std::sin(angle / 2)), 0, static_cast<float>(std::cos(angle / 2))};
}
// A turn about +x: positive turns -z towards +y (up).
XrQuaternionf pitch(double angle) {
    return {static_cast<float>(std::sin(angle / 2)), 0, 0, static_cast<float>(std::cos(angle / 2))};
}

XrQuaternionf times(const XrQuaternionf &a, const XrQuaternionf &b) {
    return {a.w * b.x + a.x * b.w + a.y * b.z - a.z * b.y, a.w * b.y - a.x * b.z + a.y * b.w + a.z * b.x,
            a.w * b.z + a.x * b.y - a.y * b.x + a.z * b.w, a.w * b.w - a.x * b.x - a.y * b.y - a.z * b.z};
}

const ViewEye kSymmetric{{0, 0, 0, 1}, {-kQuarterPi, kQuarterPi, kQuarterPi, -kQuarterPi}};

// One unit of 1/kGazeOne either way: the floats of a quaternion.
void expect_point(const std::optional<split::GazePoint> &p, double x, double y) {
    ASSERT_TRUE(p);
    EXPECT_NEAR(p->x, x * kGazeOne, 2.0);
    EXPECT_NEAR(p->y, y * kGazeOne, 2.0);
}

TEST(XrGaze, AheadIsTheCentreOfASymmetricEye) {
    expect_point(gaze_point({0, 0, 0, 1}, kSymmetric), 0.5, 0.5);
}

// Right by atan(0.5) in an eye of ±45 degrees crosses its image three quarters across; up by the
// same, a quarter of the way down.
TEST(XrGaze, RightAndUpMoveThePointRightAndUp) {
    const double a = std::atan(0.5);
    expect_point(gaze_point(yaw(-a), kSymmetric), 0.75, 0.5);
    expect_point(gaze_point(pitch(a), kSymmetric), 0.5, 0.25);
    // Right first, then up in the turned frame: the plane crossing is (0.5, 0.5 / cos a).
    const auto p = gaze_point(times(yaw(-a), pitch(a)), kSymmetric);
    ASSERT_TRUE(p);
    EXPECT_NEAR(p->x, 0.75 * kGazeOne, 2.0);
    EXPECT_LT(p->y, kGazeOne / 4);
}

// A canted display (its eye turned outward in the head, as on wide headsets): a gaze straight ahead
// in the head lies inward of that eye's centre.
TEST(XrGaze, AnEyeTurnedInTheHeadTakesTheGazeRelativeToItself) {
    const double cant = std::atan(0.5);
    const ViewEye left_canted{yaw(cant), kSymmetric.fov}; // turned left (outward for the left eye)
    expect_point(gaze_point({0, 0, 0, 1}, left_canted), 0.75, 0.5);
    // Looking along the eye's own axis: its centre.
    expect_point(gaze_point(yaw(cant), left_canted), 0.5, 0.5);
}

// The eye's orientation in the head, from a frame's view and head poses in any one space.
TEST(XrGaze, RelativeOrientationTakesTheHeadOut) {
    const XrQuaternionf head = times(yaw(0.7), pitch(-0.3)); // the head turned in the app's space
    const XrQuaternionf eye_in_head = yaw(0.1);
    const XrQuaternionf view = times(head, eye_in_head);
    const XrQuaternionf r = relative_orientation(head, view);
    EXPECT_NEAR(r.x, eye_in_head.x, 1e-6);
    EXPECT_NEAR(r.y, eye_in_head.y, 1e-6);
    EXPECT_NEAR(r.z, eye_in_head.z, 1e-6);
    EXPECT_NEAR(r.w, eye_in_head.w, 1e-6);
    // A gaze ahead in the head, in that eye: 0.1 rad right of its centre.
    const auto p = gaze_point({0, 0, 0, 1}, ViewEye{r, kSymmetric.fov});
    ASSERT_TRUE(p);
    EXPECT_NEAR(p->x, (std::tan(0.1) + 1) / 2 * kGazeOne, 2.0);
}

// Looking backwards: no point; far off to a side: clamped to the edge.
TEST(XrGaze, AGazeThatMissesTheEyeHasNoPointOrTheEdge) {
    EXPECT_FALSE(gaze_point(yaw(3.14159265), kSymmetric));
    expect_point(gaze_point(yaw(-1.2), kSymmetric), 1.0, 0.5);
}

} // namespace
} // namespace splitvk::xr
