#pragma once

// VkQueue's entry points (vk/queue.cpp): vkGetDeviceQueue*, the submits, the waits for idle.

#include "core/queue.h"
