#include "xr/xr_gaze.h"

#include "log.h"
#include "model/gaze.h"

#include <cstring>
#include <vector>

namespace splitvk::xr {
namespace {

constexpr char kProfile[] = "/interaction_profiles/ext/eye_gaze_interaction";
constexpr char kGazePose[] = "/user/eyes_ext/input/gaze_ext/pose";

struct Vec3 {
    double x, y, z;
};

Vec3 cross(const Vec3 &a, const Vec3 &b) {
    return {a.y * b.z - a.z * b.y, a.z * b.x - a.x * b.z, a.x * b.y - a.y * b.x};
}

// q v q⁻¹ for a unit quaternion.
Vec3 rotate(const XrQuaternionf &q, const Vec3 &v) {
    const Vec3 u{q.x, q.y, q.z};
    const Vec3 c = cross(u, v);
    const Vec3 t{2 * c.x, 2 * c.y, 2 * c.z};
    const Vec3 d = cross(u, t);
    return {v.x + q.w * t.x + d.x, v.y + q.w * t.y + d.y, v.z + q.w * t.z + d.z};
}

XrQuaternionf conjugate(const XrQuaternionf &q) {
    return {-q.x, -q.y, -q.z, q.w};
}

XrQuaternionf multiply(const XrQuaternionf &a, const XrQuaternionf &b) {
    return {a.w * b.x + a.x * b.w + a.y * b.z - a.z * b.y, a.w * b.y - a.x * b.z + a.y * b.w + a.z * b.x,
            a.w * b.z + a.x * b.y - a.y * b.x + a.z * b.w, a.w * b.w - a.x * b.x - a.y * b.y - a.z * b.z};
}

// An OpenXR structure of `type`, everything else zero (its `next` included).
template <typename T>
T xr_struct(XrStructureType type) {
    T t{};
    t.type = type;
    return t;
}

template <typename F>
bool load_one(PFN_xrGetInstanceProcAddr gipa, XrInstance instance, const char *name, F *out) {
    PFN_xrVoidFunction function = nullptr;
    if (XR_FAILED(gipa(instance, name, &function)) || !function) return false;
    *out = reinterpret_cast<F>(function);
    return true;
}

} // namespace

XrQuaternionf relative_orientation(const XrQuaternionf &head, const XrQuaternionf &view) {
    return multiply(conjugate(head), view);
}

std::optional<split::GazePoint> gaze_point(const XrQuaternionf &gaze_in_head, const ViewEye &eye) {
    const Vec3 in_head = rotate(gaze_in_head, {0, 0, -1});
    const Vec3 in_eye = rotate(conjugate(eye.in_head), in_head);
    return split::gaze_point_in_eye(eye.fov, in_eye.x, in_eye.y, in_eye.z);
}

bool GazeDispatch::load(PFN_xrGetInstanceProcAddr gipa, XrInstance instance) {
    return load_one(gipa, instance, "xrStringToPath", &string_to_path) &&
           load_one(gipa, instance, "xrGetSystemProperties", &get_system_properties) &&
           load_one(gipa, instance, "xrCreateActionSet", &create_action_set) &&
           load_one(gipa, instance, "xrCreateAction", &create_action) &&
           load_one(gipa, instance, "xrSuggestInteractionProfileBindings", &suggest_bindings) &&
           load_one(gipa, instance, "xrAttachSessionActionSets", &attach_action_sets) &&
           load_one(gipa, instance, "xrSyncActions", &sync_actions) &&
           load_one(gipa, instance, "xrCreateActionSpace", &create_action_space) &&
           load_one(gipa, instance, "xrCreateReferenceSpace", &create_reference_space) &&
           load_one(gipa, instance, "xrGetActionStatePose", &get_action_state_pose) &&
           load_one(gipa, instance, "xrLocateSpace", &locate_space);
}

bool InstanceGaze::system_supports(XrSystemId system) const {
    auto gaze = xr_struct<XrSystemEyeGazeInteractionPropertiesEXT>(
        XR_TYPE_SYSTEM_EYE_GAZE_INTERACTION_PROPERTIES_EXT);
    auto properties = xr_struct<XrSystemProperties>(XR_TYPE_SYSTEM_PROPERTIES);
    properties.next = &gaze;
    return XR_SUCCEEDED(vk_.get_system_properties(instance_, system, &properties)) &&
           gaze.supportsEyeGazeInteraction == XR_TRUE;
}

bool InstanceGaze::ensure_action() {
    if (action_ != XR_NULL_HANDLE) return true;
    if (failed_) return false;
    failed_ = true; // until everything below is made
    if (XR_FAILED(vk_.string_to_path(instance_, kProfile, &profile_)) ||
        XR_FAILED(vk_.string_to_path(instance_, kGazePose, &gaze_pose_))) {
        SPLITVK_WARN(
            "SPLITVK_GAZE=openxr: the runtime has no path %s; the foveae stay at the view directions",
            kProfile);
        return false;
    }
    auto set = xr_struct<XrActionSetCreateInfo>(XR_TYPE_ACTION_SET_CREATE_INFO);
    std::strncpy(set.actionSetName, "splitvk_eye_gaze", sizeof(set.actionSetName) - 1);
    std::strncpy(set.localizedActionSetName, "splitvk eye gaze", sizeof(set.localizedActionSetName) - 1);
    auto action = xr_struct<XrActionCreateInfo>(XR_TYPE_ACTION_CREATE_INFO);
    std::strncpy(action.actionName, "eye_gaze", sizeof(action.actionName) - 1);
    std::strncpy(action.localizedActionName, "eye gaze", sizeof(action.localizedActionName) - 1);
    action.actionType = XR_ACTION_TYPE_POSE_INPUT;
    XrResult result = vk_.create_action_set(instance_, &set, &set_);
    if (XR_SUCCEEDED(result)) result = vk_.create_action(set_, &action, &action_);
    if (XR_FAILED(result)) {
        SPLITVK_WARN("SPLITVK_GAZE=openxr: the runtime would not make an eye-gaze action (XrResult %d); the "
                     "foveae stay at the view directions",
                     static_cast<int>(result));
        action_ = XR_NULL_HANDLE;
        return false;
    }
    failed_ = false;
    return true;
}

XrResult InstanceGaze::suggest(const XrInteractionProfileSuggestedBinding &info) {
    if (info.interactionProfile == XR_NULL_PATH || !ensure_action() || info.interactionProfile != profile_)
        return vk_.suggest_bindings(instance_, &info);
    std::vector<XrActionSuggestedBinding> bindings(info.suggestedBindings,
                                                   info.suggestedBindings + info.countSuggestedBindings);
    bindings.push_back({action_, gaze_pose_});
    XrInteractionProfileSuggestedBinding merged = info;
    merged.countSuggestedBindings = static_cast<uint32_t>(bindings.size());
    merged.suggestedBindings = bindings.data();
    XrResult result = vk_.suggest_bindings(instance_, &merged);
    if (XR_FAILED(result)) {
        // The application's own suggestion decides what it gets back. Suggesting the layer's binding
        // alone at attach would replace the application's for this profile, so the gaze stays off.
        SPLITVK_WARN("SPLITVK_GAZE=openxr: the runtime refused the eye-gaze binding beside the application's "
                     "(XrResult %d); the foveae stay at the view directions",
                     static_cast<int>(result));
        failed_ = true;
        action_ = XR_NULL_HANDLE;
        return vk_.suggest_bindings(instance_, &info);
    }
    suggested_ = true;
    return result;
}

XrActionSet InstanceGaze::prepare_attach() {
    if (!ensure_action()) return XR_NULL_HANDLE;
    if (!suggested_) {
        const XrActionSuggestedBinding binding{action_, gaze_pose_};
        auto info =
            xr_struct<XrInteractionProfileSuggestedBinding>(XR_TYPE_INTERACTION_PROFILE_SUGGESTED_BINDING);
        info.interactionProfile = profile_;
        info.countSuggestedBindings = 1;
        info.suggestedBindings = &binding;
        if (const XrResult result = vk_.suggest_bindings(instance_, &info); XR_FAILED(result)) {
            SPLITVK_WARN(
                "SPLITVK_GAZE=openxr: the runtime refused the eye-gaze binding (XrResult %d); the foveae "
                "stay at the view directions",
                static_cast<int>(result));
            return XR_NULL_HANDLE;
        }
        suggested_ = true;
    }
    return set_;
}

void SessionGaze::attached() {
    const GazeDispatch &vk = instance_.dispatch();
    auto gaze = xr_struct<XrActionSpaceCreateInfo>(XR_TYPE_ACTION_SPACE_CREATE_INFO);
    gaze.action = instance_.action();
    gaze.poseInActionSpace.orientation.w = 1;
    auto view = xr_struct<XrReferenceSpaceCreateInfo>(XR_TYPE_REFERENCE_SPACE_CREATE_INFO);
    view.referenceSpaceType = XR_REFERENCE_SPACE_TYPE_VIEW;
    view.poseInReferenceSpace.orientation.w = 1;
    XrSpace gaze_space = XR_NULL_HANDLE;
    XrResult result = vk.create_action_space(session_, &gaze, &gaze_space);
    if (XR_SUCCEEDED(result)) result = vk.create_reference_space(session_, &view, &view_space_);
    if (XR_FAILED(result)) {
        // The spaces the layer did make go with the session.
        SPLITVK_WARN(
            "SPLITVK_GAZE=openxr: no space to locate the gaze in (XrResult %d); the foveae stay at the "
            "view directions",
            static_cast<int>(result));
        return;
    }
    gaze_space_ = gaze_space;
    SPLITVK_INFO("OpenXR session: the foveae follow the runtime's eye gaze (XR_EXT_eye_gaze_interaction)");
}

void SessionGaze::note_views(XrSpace space, XrTime display_time,
                             const XrCompositionLayerProjectionView *views, uint32_t count) {
    if (!is_attached() || !views) return;
    auto head = xr_struct<XrSpaceLocation>(XR_TYPE_SPACE_LOCATION);
    if (XR_FAILED(instance_.dispatch().locate_space(view_space_, space, display_time, &head)) ||
        !(head.locationFlags & XR_SPACE_LOCATION_ORIENTATION_VALID_BIT))
        return;
    for (uint32_t v = 0; v < count && v < eyes_.size(); ++v)
        eyes_[v] = ViewEye{
            relative_orientation(head.pose.orientation, views[v].pose.orientation),
            {views[v].fov.angleLeft, views[v].fov.angleRight, views[v].fov.angleUp, views[v].fov.angleDown}};
}

ViewGaze SessionGaze::locate(XrTime predicted) {
    const GazeDispatch &vk = instance_.dispatch();
    const auto held = [&]() -> ViewGaze {
        if (!tracked_once_) return {};
        return {shown_.eyes[0], shown_.eyes[1]};
    };
    if (!is_attached() || predicted == 0) return held();
    auto get = xr_struct<XrActionStateGetInfo>(XR_TYPE_ACTION_STATE_GET_INFO);
    get.action = instance_.action();
    auto state = xr_struct<XrActionStatePose>(XR_TYPE_ACTION_STATE_POSE);
    if (XR_FAILED(vk.get_action_state_pose(session_, &get, &state)) || !state.isActive) return held();
    auto gaze = xr_struct<XrSpaceLocation>(XR_TYPE_SPACE_LOCATION);
    constexpr XrSpaceLocationFlags kTracked =
        XR_SPACE_LOCATION_ORIENTATION_VALID_BIT | XR_SPACE_LOCATION_ORIENTATION_TRACKED_BIT;
    if (XR_FAILED(vk.locate_space(gaze_space_, view_space_, predicted, &gaze)) ||
        (gaze.locationFlags & kTracked) != kTracked)
        return held();
    split::Gaze measured = shown_;
    measured.fixed = false;
    bool any = false;
    for (size_t v = 0; v < eyes_.size(); ++v) {
        if (!eyes_[v]) continue;
        const auto point = gaze_point(gaze.pose.orientation, *eyes_[v]);
        if (!point) return held(); // the gaze points away from an eye: not a gaze to place a fovea at
        measured.eyes[v] = *point;
        any = true;
    }
    if (!any) return held();
    shown_ = tracked_once_ ? gaze::hold_fixation(shown_, measured) : measured;
    tracked_once_ = true;
    return held();
}

} // namespace splitvk::xr
