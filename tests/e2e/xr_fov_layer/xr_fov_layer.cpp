// XR_APILAYER_SPLITVK_test_skew_fov: a test-only OpenXR API layer that gives every projection view an
// application hands to xrEndFrame a fixed asymmetric field of view before passing the frame down.
// The tests enable it ABOVE splitvk's API layer (XR_ENABLE_API_LAYERS: the first named is closest to
// the application), so that splitvk sees the skewed field of view while the application rendered
// with its own: only splitvk's fovea placement changes, never the pixels the application drew.
//
// View v of a projection layer gets, in degrees (the image plane's edges at tan(angle)):
//   even v: left -45, right +20, up +20, down -45  (the view direction towards the upper right)
//   odd v:  left -20, right +45, up +20, down -45  (mirrored left to right)
// Everything but xrEndFrame goes straight to the next layer. Built into the build tree only and never
// installed.
#include "xr/xr_loader_interface.h"

#include <cstring>
#include <mutex>
#include <vector>

namespace splitvk::xr_fov_layer {
namespace {

constexpr const char *kName = "XR_APILAYER_SPLITVK_test_skew_fov";

// The one instance the tests' applications create: its next layer's entry points.
struct Instance {
    XrInstance handle = XR_NULL_HANDLE;
    PFN_xrGetInstanceProcAddr next_gipa = nullptr;
    PFN_xrEndFrame end_frame = nullptr;
};

std::mutex g_mutex;
Instance g_instance;

float radians(double degrees) {
    return static_cast<float>(degrees * 3.14159265358979323846 / 180.0);
}

XrFovf skewed(uint32_t view) {
    const float wide = radians(45), narrow = radians(20);
    if (view % 2 == 0) return {-wide, narrow, narrow, -wide};
    return {-narrow, wide, narrow, -wide};
}

XRAPI_ATTR XrResult XRAPI_CALL EndFrame(XrSession session, const XrFrameEndInfo *info) {
    PFN_xrEndFrame next = nullptr;
    {
        std::lock_guard lock(g_mutex);
        next = g_instance.end_frame;
    }
    if (!next) return XR_ERROR_HANDLE_INVALID;
    if (!info) return next(session, info);
    // Copies of the projection layers and their views, the fields of view replaced.
    std::vector<const XrCompositionLayerBaseHeader *> layers(info->layers, info->layers + info->layerCount);
    std::vector<XrCompositionLayerProjection> projections(info->layerCount);
    std::vector<std::vector<XrCompositionLayerProjectionView>> views(info->layerCount);
    for (uint32_t i = 0; i < info->layerCount; ++i) {
        const XrCompositionLayerBaseHeader *layer = info->layers[i];
        if (!layer || layer->type != XR_TYPE_COMPOSITION_LAYER_PROJECTION) continue;
        projections[i] = *reinterpret_cast<const XrCompositionLayerProjection *>(layer);
        views[i].assign(projections[i].views, projections[i].views + projections[i].viewCount);
        for (uint32_t v = 0; v < views[i].size(); ++v)
            views[i][v].fov = skewed(v);
        projections[i].views = views[i].data();
        layers[i] = reinterpret_cast<const XrCompositionLayerBaseHeader *>(&projections[i]);
    }
    XrFrameEndInfo down = *info;
    down.layers = layers.data();
    return next(session, &down);
}

XRAPI_ATTR XrResult XRAPI_CALL GetInstanceProcAddr(XrInstance instance, const char *name,
                                                   PFN_xrVoidFunction *function) {
    if (!name || !function) return XR_ERROR_VALIDATION_FAILURE;
    PFN_xrGetInstanceProcAddr next = nullptr;
    {
        std::lock_guard lock(g_mutex);
        if (instance != XR_NULL_HANDLE && instance == g_instance.handle) next = g_instance.next_gipa;
    }
    if (std::strcmp(name, "xrGetInstanceProcAddr") == 0) {
        *function = reinterpret_cast<PFN_xrVoidFunction>(GetInstanceProcAddr);
        return XR_SUCCESS;
    }
    if (!next) {
        *function = nullptr;
        return XR_ERROR_HANDLE_INVALID;
    }
    if (std::strcmp(name, "xrEndFrame") == 0) {
        *function = reinterpret_cast<PFN_xrVoidFunction>(EndFrame);
        return XR_SUCCESS;
    }
    return next(instance, name, function);
}

XRAPI_ATTR XrResult XRAPI_CALL CreateApiLayerInstance(const XrInstanceCreateInfo *info,
                                                      const XrApiLayerCreateInfo *layer_info,
                                                      XrInstance *instance) {
    if (!layer_info || !layer_info->nextInfo ||
        std::strncmp(layer_info->nextInfo->layerName, kName, XR_MAX_API_LAYER_NAME_SIZE) != 0)
        return XR_ERROR_INITIALIZATION_FAILED;
    const XrApiLayerNextInfo &next = *layer_info->nextInfo;
    XrApiLayerCreateInfo down = *layer_info;
    down.nextInfo = next.next;
    const XrResult result = next.nextCreateApiLayerInstance(info, &down, instance);
    if (XR_FAILED(result)) return result;
    Instance state;
    state.handle = *instance;
    state.next_gipa = next.nextGetInstanceProcAddr;
    PFN_xrVoidFunction end_frame = nullptr;
    if (XR_FAILED(state.next_gipa(*instance, "xrEndFrame", &end_frame)) || !end_frame)
        return XR_ERROR_INITIALIZATION_FAILED;
    state.end_frame = reinterpret_cast<PFN_xrEndFrame>(end_frame);
    std::lock_guard lock(g_mutex);
    g_instance = state;
    return result;
}

} // namespace
} // namespace splitvk::xr_fov_layer

extern "C" __attribute__((visibility("default"))) XrResult XRAPI_CALL xrNegotiateLoaderApiLayerInterface(
    const XrNegotiateLoaderInfo *loader_info, const char *layer_name, XrNegotiateApiLayerRequest *request) {
    using namespace splitvk::xr_fov_layer;
    if (!loader_info || !request || loader_info->structType != XR_LOADER_INTERFACE_STRUCT_LOADER_INFO ||
        request->structType != XR_LOADER_INTERFACE_STRUCT_API_LAYER_REQUEST ||
        request->structSize != sizeof(XrNegotiateApiLayerRequest))
        return XR_ERROR_INITIALIZATION_FAILED;
    if (layer_name && std::strcmp(layer_name, kName) != 0) return XR_ERROR_INITIALIZATION_FAILED;
    if (loader_info->minInterfaceVersion > XR_CURRENT_LOADER_API_LAYER_VERSION ||
        loader_info->maxInterfaceVersion < XR_CURRENT_LOADER_API_LAYER_VERSION)
        return XR_ERROR_INITIALIZATION_FAILED;
    request->layerInterfaceVersion = XR_CURRENT_LOADER_API_LAYER_VERSION;
    request->layerApiVersion = XR_CURRENT_API_VERSION;
    request->getInstanceProcAddr = GetInstanceProcAddr;
    request->createApiLayerInstance = CreateApiLayerInstance;
    return XR_SUCCESS;
}
