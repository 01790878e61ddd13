#pragma once

// Copies, blits, resolves and dispatches that name regions of screen-space targets (screen_space.h)
// or write a swapchain image. Each side of a transfer is one of three kinds, looked up by handle:
// a screen-space target (its regions scale into the scaled image), a swapchain image written while
// splitting (the region lands in the scaled top-left, like a split pass, and the foveae of the eyes
// it covers are noted, as the agent notes them: fovea_shading.cpp), or any other image (unchanged).
// The capture keeps the application's call.
//
// Copies and resolves need the same extent on both sides; where only one side is scaled the
// periphery holds the scaled picture in the other image's top-left (one info line): a copy into a
// swapchain image from a full-size image is left whole and unsplit instead, which is exact.
//
// Dispatches: a dispatch whose bound compute descriptor sets (its command buffer's split tracker,
// begun afresh with each recording: command_buffer.h) write a screen-space target has its group
// counts (and bases) scaled; an indirect one cannot be and runs unscaled (one info line).
//
// What this file defines are the hand-written hooks of generated entry points (observe:: and
// rewrite::, codegen/layer_overrides.py), declared in the generated layer_entry_points.h.

#include "layer_entry_points.h"
