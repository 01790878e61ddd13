#pragma once

#include "settings.h"

namespace splitvk {

inline constexpr const char *kLayerName = "VK_LAYER_SPLITVK_split_render";

// SPLITVK_DISABLE=1: the layer must stay out of the application entirely.
bool disabled_by_environment();

// The process's settings, parsed and reported (one line per problem) on first use.
const LoadedSettings &layer_settings();

} // namespace splitvk
