#pragma once

// SPLITVK_GAZE=openxr: the runtime's eye tracking moves the foveae of OpenXR eye images.
//
// The application never knows. At xrCreateInstance the layer adds XR_EXT_eye_gaze_interaction where
// the runtime has it; where the system supports eye gaze, it creates an action set of its own with
// one pose action, suggests its binding (/user/eyes_ext/input/gaze_ext/pose) beside whatever the
// application suggests for the eye-gaze profile (a suggestion replaces the previous one for its
// profile, so the application's own bindings are merged in, never replaced), attaches it with the
// application's action sets and makes it active in each of the application's xrSyncActions.
//
// Where the eyes look is the gaze pose's -z axis, located in the VIEW space (the head) at the
// frame's predicted display time at xrBeginFrame, before the frame is rendered. Each eye's
// orientation in the head and its field of view come from the previous frame's projection views
// (they change with the headset's IPD at most), so the gaze projects into each eye's image
// (split::gaze_point_in_eye) with that frame's own head pose taken out.
//
// Without a valid gaze (the runtime says the action or the orientation is not tracked: a blink, a
// lost eye), the last point holds; before the first, the foveae sit at the view directions.

#include "split_geometry.h"

#include <array>
#include <atomic>
#include <optional>

#include <openxr/openxr.h>

namespace splitvk::xr {

// An eye as a frame's projection view gave it: its orientation relative to the head (VIEW space)
// and its field of view.
struct ViewEye {
    XrQuaternionf in_head{0, 0, 0, 1};
    split::FieldOfView fov;
};

// `view`'s orientation relative to `head`, both given in one space (head⁻¹ · view).
XrQuaternionf relative_orientation(const XrQuaternionf &head, const XrQuaternionf &view);

// Where a gaze of orientation `gaze_in_head` (it looks down its own -z) falls in `eye`'s image;
// nothing where it does not point into the eye's front half-space.
std::optional<split::GazePoint> gaze_point(const XrQuaternionf &gaze_in_head, const ViewEye &eye);

// The application's views 0 and 1 (left, right), each eye's gaze point this frame where known.
using ViewGaze = std::array<std::optional<split::GazePoint>, 2>;

// The runtime's (or next layer's) functions the eye-gaze action needs, per XrInstance.
struct GazeDispatch {
    PFN_xrStringToPath string_to_path = nullptr;
    PFN_xrGetSystemProperties get_system_properties = nullptr;
    PFN_xrCreateActionSet create_action_set = nullptr;
    PFN_xrCreateAction create_action = nullptr;
    PFN_xrSuggestInteractionProfileBindings suggest_bindings = nullptr;
    PFN_xrAttachSessionActionSets attach_action_sets = nullptr;
    PFN_xrSyncActions sync_actions = nullptr;
    PFN_xrCreateActionSpace create_action_space = nullptr;
    PFN_xrCreateReferenceSpace create_reference_space = nullptr;
    PFN_xrGetActionStatePose get_action_state_pose = nullptr;
    PFN_xrLocateSpace locate_space = nullptr;

    bool load(PFN_xrGetInstanceProcAddr get_instance_proc_addr, XrInstance instance);
};

// The eye-gaze action of one XrInstance whose runtime took XR_EXT_eye_gaze_interaction.
class InstanceGaze {
public:
    InstanceGaze(XrInstance instance, const GazeDispatch &dispatch) : instance_(instance), vk_(dispatch) {}

    const GazeDispatch &dispatch() const { return vk_; }
    // Whether `system` tracks the eyes (XrSystemEyeGazeInteractionPropertiesEXT).
    bool system_supports(XrSystemId system) const;
    // xrSuggestInteractionProfileBindings: the application's suggestion, with the layer's binding
    // added where it is for the eye-gaze profile.
    XrResult suggest(const XrInteractionProfileSuggestedBinding &info);
    // The action set to attach beside the application's, its binding suggested (alone, where the
    // application suggested nothing for the eye-gaze profile); null where it cannot be made. Bindings
    // are fixed from a session's first attach on, so the suggestion is made once per instance.
    XrActionSet prepare_attach();
    XrActionSet action_set() const { return set_; }
    XrAction action() const { return action_; }

private:
    bool ensure_action();

    XrInstance instance_;
    GazeDispatch vk_;
    XrActionSet set_ = XR_NULL_HANDLE;
    XrAction action_ = XR_NULL_HANDLE;
    XrPath profile_ = XR_NULL_PATH;
    XrPath gaze_pose_ = XR_NULL_PATH;
    bool failed_ = false;
    bool suggested_ = false; // the layer's binding is suggested, alone or merged
};

// The eye gaze of one XrSession of such an instance, on a system that tracks the eyes.
class SessionGaze {
public:
    SessionGaze(XrSession session, InstanceGaze &instance) : session_(session), instance_(instance) {}

    // xrAttachSessionActionSets went through with the layer's set: its spaces.
    void attached();
    bool is_attached() const { return gaze_space_ != XR_NULL_HANDLE; }
    // xrWaitFrame (which may run on another thread than the frame's other calls).
    void frame_waited(XrTime predicted_display_time) { predicted_.store(predicted_display_time); }
    XrTime predicted() const { return predicted_.load(); }
    // xrEndFrame: each of the first two projection views' eye in the head, from the frame's head pose
    // in the layer's space.
    void note_views(XrSpace space, XrTime display_time, const XrCompositionLayerProjectionView *views,
                    uint32_t count);
    // xrBeginFrame: where each view's eye looks at `display_time`, the frame's predicted display
    // time (held through fixations, as gaze::hold_fixation holds a pipe's points).
    ViewGaze locate(XrTime display_time);

private:
    XrSession session_;
    InstanceGaze &instance_;
    XrSpace gaze_space_ = XR_NULL_HANDLE;
    XrSpace view_space_ = XR_NULL_HANDLE;
    std::atomic<XrTime> predicted_{0};
    std::array<std::optional<ViewEye>, 2> eyes_;
    split::Gaze shown_; // per view, as held
    bool tracked_once_ = false;
};

} // namespace splitvk::xr
