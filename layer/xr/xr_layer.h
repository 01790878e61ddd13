#pragma once

// XR_APILAYER_SPLITVK_split_render, the OpenXR API layer (xr_layer.cpp): what the OpenXR loader
// calls by name (the manifest's functions.xrNegotiateLoaderApiLayerInterface, layer.map).

#include "xr/xr_loader_interface.h"

extern "C" __attribute__((visibility("default"))) XrResult XRAPI_CALL xrNegotiateLoaderApiLayerInterface(
    const XrNegotiateLoaderInfo *loader_info, const char *layer_name, XrNegotiateApiLayerRequest *request);
