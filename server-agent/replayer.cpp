#include "replayer.h"

#include "log.h"
#include "submit_rules.h"
#include "vk_format_info.h"

#include <algorithm>
#include <cstdio>
#include <cstring>
#include <string_view>

namespace splitvk::agent {

using codec::VkCommandId;

namespace {

std::string hex(uint64_t v) {
    char text[24];
    std::snprintf(text, sizeof(text), "0x%llx", static_cast<unsigned long long>(v));
    return text;
}

} // namespace

Replayer::Replayer(uint64_t session_id, const MemoryLimits &limits, protocol::DeviceDescription device)
    : session_id_(session_id), memory_(context_, limits), guard_(session_id, std::move(device)) {
    table = &table_;
    // Whole frames until the client's SplitConfig says it splits (a verifying client does only in the
    // swapped split, which replays whole frames all the same).
    fovea_.set_enabled(false);
}

Replayer::~Replayer() {
    if (!context_.device) return;
    vkDeviceWaitIdle(context_.device);
    if (variant_pool_) ::vkDestroyCommandPool(context_.device, variant_pool_, nullptr);
    for (const auto &[serial, fence] : in_flight_)
        ::vkDestroyFence(context_.device, fence, nullptr);
    for (VkFence fence : free_fences_)
        ::vkDestroyFence(context_.device, fence, nullptr);
}

VkFence Replayer::submit_fence() {
    while (!in_flight_.empty() &&
           vkGetFenceStatus(context_.device, in_flight_.front().second) == VK_SUCCESS) {
        free_fences_.push_back(in_flight_.front().second);
        in_flight_.pop_front();
    }
    if (!free_fences_.empty()) {
        const VkFence fence = free_fences_.back();
        free_fences_.pop_back();
        ::vkResetFences(context_.device, 1, &fence);
        return fence;
    }
    VkFenceCreateInfo info{};
    info.sType = VK_STRUCTURE_TYPE_FENCE_CREATE_INFO;
    VkFence fence = VK_NULL_HANDLE;
    return ::vkCreateFence(context_.device, &info, nullptr, &fence) == VK_SUCCESS ? fence : VK_NULL_HANDLE;
}

void Replayer::reclaim_fences(uint64_t up_to) {
    constexpr uint64_t kWaitNs = 30'000'000'000; // a submit that long is a lost GPU
    while (!in_flight_.empty() && in_flight_.front().first <= up_to) {
        if (vkWaitForFences(context_.device, 1, &in_flight_.front().second, VK_TRUE, kWaitNs) != VK_SUCCESS) {
            quiesce(); // no answer from the fence: the queue, as before
            return;
        }
        free_fences_.push_back(in_flight_.front().second);
        in_flight_.pop_front();
    }
}

void Replayer::wait_for_command_pool(std::span<const uint8_t> payload, size_t offset) {
    if (!gpu_busy_) return;
    // Encoded: u16 command id, u64 device id, u64 commandPool id.
    if (payload.size() - offset < 18) return quiesce(); // the decoder reports the truncation
    const auto *entry = table_.find(protocol::load_le64(payload.data() + offset + 10));
    if (!entry) return quiesce();
    const auto pool = codec::to_handle<VkCommandPool>(entry->handle);
    // Secondaries of the pool may be inside pending primaries of any pool.
    if (pools_with_secondaries_.count(pool)) return quiesce();
    const auto last = pool_last_submit_.find(pool);
    if (last == pool_last_submit_.end()) return; // nothing of it ever submitted
    if (!flush_writes()) return;
    reclaim_fences(last->second);
}

bool Replayer::vkAllocateCommandBuffers(const codec::Decoded_vkAllocateCommandBuffers &c) {
    if (!ReplayVisitorBase::vkAllocateCommandBuffers(c)) return false;
    const VkCommandPool pool = c.pAllocateInfo->commandPool;
    if (c.pAllocateInfo->level == VK_COMMAND_BUFFER_LEVEL_SECONDARY) pools_with_secondaries_.insert(pool);
    for (uint32_t i = 0; i < c.pCommandBuffers_count; ++i)
        pool_of_[c.pCommandBuffers[i]] = pool;
    return true;
}

void Replayer::note_submitted(VkCommandBuffer cb) {
    last_submit_[cb] = submit_serial_;
    if (const auto pool = pool_of_.find(cb); pool != pool_of_.end())
        pool_last_submit_[pool->second] = submit_serial_;
}

void Replayer::wait_for_command_buffer(std::span<const uint8_t> payload, size_t offset) {
    if (!gpu_busy_) return;
    if (payload.size() - offset < 10) return quiesce(); // the decoder reports the truncation
    const auto *entry = table_.find(protocol::load_le64(payload.data() + offset + 2));
    const auto last =
        entry ? last_submit_.find(codec::to_handle<VkCommandBuffer>(entry->handle)) : last_submit_.end();
    if (last == last_submit_.end()) return quiesce();
    if (!flush_writes()) return;
    reclaim_fences(last->second);
}

bool Replayer::init(uint32_t device_index, bool validate, std::string *error) {
    return context_.create_instance(device_index, validate, session_id_, error);
}

bool Replayer::failed(const char *command, VkResult result, const std::string &detail) {
    if (!error_.empty()) return false; // the first error is the one reported
    error_ = command;
    if (result != VK_SUCCESS) error_ += std::string(": ") + vk_result_name(result);
    if (!detail.empty()) error_ += ": " + detail;
    return false;
}

bool Replayer::unhandled(VkCommandId id) {
    return failed(codec::command_name(id), VK_SUCCESS,
                  "not replayed by the agent (the layer must not send it)");
}

bool Replayer::flush_writes() {
    if (!writes_.pending()) return true;
    std::string error;
    if (!writes_.flush(&error)) return failed("MemoryData", VK_SUCCESS, error);
    gpu_busy_ = true;
    return true;
}

void Replayer::quiesce() {
    flush_writes(); // a failure is the session's error (failed())
    if (!gpu_busy_ || !context_.queue) return;
    vkQueueWaitIdle(context_.queue);
    gpu_busy_ = false;
    for (const auto &[serial, fence] : in_flight_)
        free_fences_.push_back(fence);
    in_flight_.clear();
}

bool Replayer::needs_quiesce(VkCommandId id) const {
    const std::string_view name = codec::command_name(id);
    // vkResetFences: the client's fences are its own; the agent's handler does nothing.
    for (std::string_view safe : {"vkCmd", "vkCreate", "vkAllocate", "vkGet", "vkQueueSubmit",
                                  "vkEndCommandBuffer", "vkBind", "vkResetFences"})
        if (name.substr(0, safe.size()) == safe) return false;
    return true;
}

// vkCreateDevice names the client's VkPhysicalDevice, which the stream never created: register
// that id for the agent's GPU before the command is decoded (encoded layout: u16 command id, then
// the u64 physicalDevice id).
bool Replayer::peek_create_device(std::span<const uint8_t> payload, size_t offset, std::string *error) {
    if (payload.size() - offset < 10) return true; // the decoder reports the truncation
    const uint64_t id = protocol::load_le64(payload.data() + offset + 2);
    if (id == 0) return true; // the decoder reports the null handle
    const auto *entry = table_.find(id);
    if (entry && entry->type == VK_OBJECT_TYPE_PHYSICAL_DEVICE) return true;
    return table_.insert(id, VK_OBJECT_TYPE_PHYSICAL_DEVICE, context_.physical_device, 0, error);
}

bool Replayer::replay(std::span<const uint8_t> payload, std::string *error) {
    error->clear();
    codec::Decoder d(payload, table_, arena_);
    bool ok = true;
    // Where each command buffer begun in this payload began (a command buffer's stream is sent whole).
    std::unordered_map<uint64_t, size_t> begun_at;
    while (ok && d.ok() && !d.at_end()) {
        const size_t offset = d.offset();
        bool ends_command_buffer = false; // its stream is complete once dispatched
        bool begins_command_buffer = false;
        if (payload.size() - offset >= 2) {
            const auto id = static_cast<VkCommandId>(protocol::load_le16(payload.data() + offset));
            // Both encoded as u16 command id, u64 commandBuffer id.
            if ((id == VkCommandId::vkBeginCommandBuffer || id == VkCommandId::vkEndCommandBuffer) &&
                payload.size() - offset >= 10) {
                const uint64_t command_buffer = protocol::load_le64(payload.data() + offset + 2);
                if (id == VkCommandId::vkBeginCommandBuffer) begun_at[command_buffer] = offset;
                begins_command_buffer = id == VkCommandId::vkBeginCommandBuffer;
                ends_command_buffer = id == VkCommandId::vkEndCommandBuffer;
            }
            if (id == VkCommandId::vkCreateDevice && !peek_create_device(payload, offset, error)) {
                *error = "vkCreateDevice: " + *error;
                ok = false;
                break;
            }
            if (id == VkCommandId::vkBeginCommandBuffer || id == VkCommandId::vkResetCommandBuffer)
                wait_for_command_buffer(payload, offset);
            else if (id == VkCommandId::vkResetCommandPool)
                wait_for_command_pool(payload, offset);
            else if (codec::is_command_id(static_cast<uint16_t>(id)) && needs_quiesce(id)) {
                quiesce();
                // Freed command buffers: a later one (a secondary) may get the same handle value.
                if (id == VkCommandId::vkFreeCommandBuffers || id == VkCommandId::vkDestroyCommandPool) {
                    last_submit_.clear();
                    pool_of_.clear();
                    pool_last_submit_.clear();
                    pools_with_secondaries_.clear();
                }
            }
        }
        ok = codec::dispatch_decoded(d, *this);
        if (ok) ++commands_;
        if (ok && d.ok() && begins_command_buffer) {
            const uint64_t command_buffer = protocol::load_le64(payload.data() + offset + 2);
            if (const auto *entry = table_.find(command_buffer))
                prescan_transfer_reads(payload, d.offset(), command_buffer,
                                       codec::to_handle<VkCommandBuffer>(entry->handle));
        }
        if (ok && d.ok() && ends_command_buffer) {
            const uint64_t command_buffer = protocol::load_le64(payload.data() + offset + 2);
            if (const auto begin = begun_at.find(command_buffer); begin != begun_at.end())
                keep_secondary_stream(command_buffer,
                                      payload.subspan(begin->second, d.offset() - begin->second));
        }
    }
    if (ok && d.ok()) {
        arena_.reset();
        return true;
    }
    if (!d.ok())
        *error = d.error();
    else if (error->empty())
        *error = error_.empty() ? std::string("replay refused a command") : error_;
    arena_.reset();
    return false;
}

// --- instance, device, queues ---------------------------------------------------------------

bool Replayer::vkCreateInstance(const codec::Decoded_vkCreateInstance &c) {
    // The client's instance is informative; its id stands for the agent's own.
    if (c.pInstance && c.pInstance_count) c.pInstance[0] = context_.instance;
    std::string error;
    if (!codec::apply_handle_changes(table_, c, &error)) return failed("vkCreateInstance", VK_SUCCESS, error);
    return true;
}

bool Replayer::vkDestroyInstance(const codec::Decoded_vkDestroyInstance &) {
    return true; // the session's instance lives as long as the session
}

bool Replayer::vkCreateDevice(const codec::Decoded_vkCreateDevice &c) {
    if (context_.device) return failed("vkCreateDevice", VK_SUCCESS, "a session replays one device");
    std::string error;
    const VkResult r = context_.create_device(*c.pCreateInfo, &error);
    if (r != VK_SUCCESS) return failed("vkCreateDevice", VK_SUCCESS, error);
    vk.load(vkGetDeviceProcAddr, context_.device);
    if (c.pDevice && c.pDevice_count) c.pDevice[0] = context_.device;
    if (!codec::apply_handle_changes(table_, c, &error)) return failed("vkCreateDevice", VK_SUCCESS, error);
    SPLITVK_INFO("session %llu: device created on %s (Vulkan %u.%u%s)",
                 static_cast<unsigned long long>(session_id_), context_.gpu_name.c_str(),
                 VK_API_VERSION_MAJOR(context_.api_version), VK_API_VERSION_MINOR(context_.api_version),
                 context_.swapchain_extension ? ", VK_KHR_swapchain"
                                              : ", no VK_KHR_swapchain: PRESENT_SRC_KHR is invalid");
    return true;
}

bool Replayer::vkDestroyDevice(const codec::Decoded_vkDestroyDevice &) {
    // The session ends with the process, which frees the device and what the client left alive.
    quiesce();
    return true;
}

bool Replayer::vkGetDeviceQueue(const codec::Decoded_vkGetDeviceQueue &c) {
    // Every client queue is the agent's one graphics queue: submits run in order on it.
    if (c.pQueue && c.pQueue_count) c.pQueue[0] = context_.queue;
    std::string error;
    if (!codec::apply_handle_changes(table_, c, &error)) return failed("vkGetDeviceQueue", VK_SUCCESS, error);
    return true;
}

bool Replayer::vkGetDeviceQueue2(const codec::Decoded_vkGetDeviceQueue2 &c) {
    if (c.pQueue && c.pQueue_count) c.pQueue[0] = context_.queue;
    std::string error;
    if (!codec::apply_handle_changes(table_, c, &error))
        return failed("vkGetDeviceQueue2", VK_SUCCESS, error);
    return true;
}

// --- submits: in order on one queue; the client's semaphores and fences are its own ------------

bool Replayer::vkQueueSubmit(const codec::Decoded_vkQueueSubmit &c) {
    auto submits = codec::without_synchronization(c.pSubmits, c.submitCount);
    // Command buffers with addresses the agent cannot translate never run (LimitGuard::must_skip).
    std::vector<std::vector<VkCommandBuffer>> kept(submits.size());
    for (size_t s = 0; s < submits.size(); ++s) {
        const VkSubmitInfo &submit = submits[s];
        for (uint32_t i = 0; i < submit.commandBufferCount; ++i)
            if (!guard_.must_skip(submit.pCommandBuffers[i])) kept[s].push_back(submit.pCommandBuffers[i]);
        if (kept[s].size() == submit.commandBufferCount) continue;
        submits[s].commandBufferCount = static_cast<uint32_t>(kept[s].size());
        submits[s].pCommandBuffers = kept[s].data();
    }
    if (!flush_writes()) return false; // the memory data the client wrote before this submit
    note_frame_submit();
    const VkFence fence = submit_fence();
    const VkResult r =
        ::vkQueueSubmit(context_.queue, static_cast<uint32_t>(submits.size()), submits.data(), fence);
    if (r != VK_SUCCESS) return failed("vkQueueSubmit", r);
    if (fence) {
        in_flight_.emplace_back(++submit_serial_, fence);
        for (const VkSubmitInfo &s : submits)
            for (uint32_t i = 0; i < s.commandBufferCount; ++i)
                note_submitted(s.pCommandBuffers[i]);
    }
    for (uint32_t s = 0; s < c.submitCount; ++s) {
        fovea_.submitted(c.pSubmits[s].commandBufferCount, c.pSubmits[s].pCommandBuffers);
        scaling_.submitted(c.pSubmits[s].commandBufferCount, c.pSubmits[s].pCommandBuffers);
        guard_.submitted(c.pSubmits[s].commandBufferCount, c.pSubmits[s].pCommandBuffers);
    }
    gpu_busy_ = true;
    ++submits_;
    return true;
}

bool Replayer::vkQueueSubmit2(const codec::Decoded_vkQueueSubmit2 &c) {
    if (!vk.QueueSubmit2) return missing("vkQueueSubmit2");
    auto submits = codec::without_synchronization(c.pSubmits, c.submitCount);
    std::vector<std::vector<VkCommandBufferSubmitInfo>> kept(submits.size());
    for (size_t s = 0; s < submits.size(); ++s) {
        const VkSubmitInfo2 &submit = submits[s];
        for (uint32_t i = 0; i < submit.commandBufferInfoCount; ++i)
            if (!guard_.must_skip(submit.pCommandBufferInfos[i].commandBuffer))
                kept[s].push_back(submit.pCommandBufferInfos[i]);
        if (kept[s].size() == submit.commandBufferInfoCount) continue;
        submits[s].commandBufferInfoCount = static_cast<uint32_t>(kept[s].size());
        submits[s].pCommandBufferInfos = kept[s].data();
    }
    if (!flush_writes()) return false;
    note_frame_submit();
    const VkFence fence = submit_fence();
    const VkResult r =
        vk.QueueSubmit2(context_.queue, static_cast<uint32_t>(submits.size()), submits.data(), fence);
    if (r != VK_SUCCESS) return failed("vkQueueSubmit2", r);
    if (fence) {
        in_flight_.emplace_back(++submit_serial_, fence);
        for (const VkSubmitInfo2 &s : submits)
            for (uint32_t i = 0; i < s.commandBufferInfoCount; ++i)
                note_submitted(s.pCommandBufferInfos[i].commandBuffer);
    }
    for (uint32_t s = 0; s < c.submitCount; ++s)
        for (uint32_t i = 0; i < c.pSubmits[s].commandBufferInfoCount; ++i) {
            fovea_.submitted(1, &c.pSubmits[s].pCommandBufferInfos[i].commandBuffer);
            scaling_.submitted(1, &c.pSubmits[s].pCommandBufferInfos[i].commandBuffer);
            guard_.submitted(1, &c.pSubmits[s].pCommandBufferInfos[i].commandBuffer);
        }
    gpu_busy_ = true;
    ++submits_;
    return true;
}

// --- memory: rebind -------------------------------------------------------------------------

bool Replayer::vkAllocateMemory(const codec::Decoded_vkAllocateMemory &c) {
    if (!c.pMemory || !c.pMemory_ids || c.pMemory_count == 0) return true;
    const uint64_t id = c.pMemory_ids[0];
    std::string error;
    if (id == 0) return true;
    if (!memory_.allocate(id, c.pAllocateInfo->allocationSize, &error))
        return failed("vkAllocateMemory", VK_SUCCESS, error);
    // The table's handle for a client memory object is its id: nothing is allocated on the GPU
    // until a resource is bound, and no forwarded command passes a VkDeviceMemory to the driver.
    c.pMemory[0] = codec::to_handle<VkDeviceMemory>(id);
    if (!codec::apply_handle_changes(table_, c, &error)) return failed("vkAllocateMemory", VK_SUCCESS, error);
    return true;
}

bool Replayer::vkFreeMemory(const codec::Decoded_vkFreeMemory &c) {
    memory_.free(c.memory_id);
    std::string error;
    if (!codec::apply_handle_changes(table_, c, &error)) return failed("vkFreeMemory", VK_SUCCESS, error);
    return true;
}

// Mapping is the client's business: what the host writes arrives as MemoryData.
bool Replayer::vkMapMemory(const codec::Decoded_vkMapMemory &) {
    return true;
}
bool Replayer::vkUnmapMemory(const codec::Decoded_vkUnmapMemory &) {
    return true;
}
bool Replayer::vkFlushMappedMemoryRanges(const codec::Decoded_vkFlushMappedMemoryRanges &) {
    return true;
}
bool Replayer::vkInvalidateMappedMemoryRanges(const codec::Decoded_vkInvalidateMappedMemoryRanges &) {
    return true;
}
bool Replayer::vkResetFences(const codec::Decoded_vkResetFences &) {
    return true; // fences are answered by the client's driver
}

bool Replayer::vkBindBufferMemory(const codec::Decoded_vkBindBufferMemory &c) {
    std::string error;
    if (!memory_.bind_buffer(c.buffer, c.memory_id, c.memoryOffset, &error))
        return failed("vkBindBufferMemory", VK_SUCCESS, "buffer " + hex(c.buffer_id) + ": " + error);
    return true;
}

bool Replayer::vkBindBufferMemory2(const codec::Decoded_vkBindBufferMemory2 &c) {
    for (uint32_t i = 0; i < c.bindInfoCount; ++i) {
        const auto &info = c.pBindInfos[i];
        std::string error;
        if (!memory_.bind_buffer(info.buffer, codec::handle_value(info.memory), info.memoryOffset, &error))
            return failed("vkBindBufferMemory2", VK_SUCCESS,
                          "pBindInfos[" + std::to_string(i) + "]: " + error);
    }
    return true;
}

bool Replayer::vkBindImageMemory(const codec::Decoded_vkBindImageMemory &c) {
    std::string error;
    if (!memory_.bind_image(c.image, c.memory_id, c.memoryOffset, &error))
        return failed("vkBindImageMemory", VK_SUCCESS, "image " + hex(c.image_id) + ": " + error);
    return true;
}

bool Replayer::vkBindImageMemory2(const codec::Decoded_vkBindImageMemory2 &c) {
    for (uint32_t i = 0; i < c.bindInfoCount; ++i) {
        const auto &info = c.pBindInfos[i];
        std::string error;
        if (!memory_.bind_image(info.image, codec::handle_value(info.memory), info.memoryOffset, &error))
            return failed("vkBindImageMemory2", VK_SUCCESS,
                          "pBindInfos[" + std::to_string(i) + "]: " + error);
    }
    return true;
}

bool Replayer::vkCreateBuffer(const codec::Decoded_vkCreateBuffer &c) {
    // MemoryData reaches buffers by GPU copies when the GPU is busy (queued_writes.h).
    VkBufferCreateInfo info = *c.pCreateInfo;
    info.usage |= VK_BUFFER_USAGE_TRANSFER_DST_BIT;
    auto copy = c;
    copy.pCreateInfo = &info;
    if (!ReplayVisitorBase::vkCreateBuffer(copy)) return false;
    memory_.buffer_created(c.pBuffer[0], *c.pCreateInfo);
    return true;
}

bool Replayer::vkDestroyBuffer(const codec::Decoded_vkDestroyBuffer &c) {
    addresses_.erase(codec::handle_value(c.buffer));
    if (!ReplayVisitorBase::vkDestroyBuffer(c)) return false;
    memory_.buffer_destroyed(c.buffer);
    return true;
}

bool Replayer::vkCreateImage(const codec::Decoded_vkCreateImage &c) {
    guard_.image_created(*c.pCreateInfo);
    // The live-state snapshot that brings this agent in after the client started (a late join, a
    // reconnect, SPLITVK_SPLIT=auto calling it back) writes every image's contents with a copy into
    // it, which the application's usage need not allow (a texture it fills through mapped memory is
    // SAMPLED alone): the image gets TRANSFER_DST as well, where this GPU takes it for the image.
    VkImageCreateInfo info = *c.pCreateInfo;
    if (!(info.usage & VK_IMAGE_USAGE_TRANSFER_DST_BIT) &&
        info.tiling != VK_IMAGE_TILING_DRM_FORMAT_MODIFIER_EXT) {
        VkImageFormatProperties properties{};
        if (vkGetPhysicalDeviceImageFormatProperties(
                context_.physical_device, info.format, info.imageType, info.tiling,
                info.usage | VK_IMAGE_USAGE_TRANSFER_DST_BIT, info.flags, &properties) == VK_SUCCESS)
            info.usage |= VK_IMAGE_USAGE_TRANSFER_DST_BIT;
    }
    auto copy = c;
    copy.pCreateInfo = &info;
    if (!ReplayVisitorBase::vkCreateImage(copy)) return false;
    memory_.image_created(c.pImage[0], *c.pCreateInfo);
    fovea_.image_created(c.pImage[0], *c.pCreateInfo);
    swapchains_.image_created(c.pImage[0], *c.pCreateInfo);
    return true;
}

bool Replayer::vkDestroyImage(const codec::Decoded_vkDestroyImage &c) {
    if (!ReplayVisitorBase::vkDestroyImage(c)) return false;
    memory_.image_destroyed(c.image);
    fovea_.image_destroyed(c.image);
    swapchains_.image_destroyed(c.image);
    return true;
}

// --- pipelines: the client's pipeline cache is not used ---------------------------------------

bool Replayer::vkCreateGraphicsPipelines(const codec::Decoded_vkCreateGraphicsPipelines &c) {
    auto copy = c;
    copy.pipelineCache = VK_NULL_HANDLE;
    // At most one of the two rewrites: fovea shading is off in the swapped split, scaling outside it.
    copy.pCreateInfos = scaling_.prepare_pipelines(
        c.createInfoCount, fovea_.prepare_pipelines(c.createInfoCount, c.pCreateInfos));
    if (!ReplayVisitorBase::vkCreateGraphicsPipelines(copy)) return false;
    fovea_.pipelines_created(c.pPipelines_count, c.pPipelines);
    scaling_.pipelines_created(c.pPipelines_count, c.pPipelines);
    for (uint32_t i = 0; i < c.createInfoCount && i < c.pPipelines_count; ++i)
        note_pipeline_addresses(c.pPipelines[i], c.pCreateInfos[i].layout, c.pCreateInfos[i].stageCount,
                                c.pCreateInfos[i].pStages);
    return true;
}

bool Replayer::vkCreateComputePipelines(const codec::Decoded_vkCreateComputePipelines &c) {
    auto copy = c;
    copy.pipelineCache = VK_NULL_HANDLE;
    if (!ReplayVisitorBase::vkCreateComputePipelines(copy)) return false;
    for (uint32_t i = 0; i < c.createInfoCount && i < c.pPipelines_count; ++i)
        note_pipeline_addresses(c.pPipelines[i], c.pCreateInfos[i].layout, 1, &c.pCreateInfos[i].stage);
    return true;
}

// --- buffer device addresses (buffer_addresses.h) --------------------------------------------

bool Replayer::vkCreateShaderModule(const codec::Decoded_vkCreateShaderModule &c) {
    if (!ReplayVisitorBase::vkCreateShaderModule(c)) return false;
    ShaderAddresses found;
    std::string error;
    const std::span<const uint32_t> words(c.pCreateInfo->pCode, c.pCreateInfo->codeSize / sizeof(uint32_t));
    if (!reflect_shader_addresses(words, &found, &error)) {
        // The driver took it, this reader did not: whatever addresses it uses stay untranslated.
        found.uses_addresses = may_use_addresses(words);
        found.untranslatable = "a module splitvk cannot read (" + error + ")";
    }
    if (found.uses_addresses) shader_addresses_[c.pShaderModule[0]] = std::move(found);
    return true;
}

bool Replayer::vkDestroyShaderModule(const codec::Decoded_vkDestroyShaderModule &c) {
    shader_addresses_.erase(c.shaderModule);
    return ReplayVisitorBase::vkDestroyShaderModule(c);
}

bool Replayer::vkDestroyPipelineLayout(const codec::Decoded_vkDestroyPipelineLayout &c) {
    layout_address_fields_.erase(c.pipelineLayout);
    return ReplayVisitorBase::vkDestroyPipelineLayout(c);
}

void Replayer::note_pipeline_addresses(VkPipeline pipeline, VkPipelineLayout layout, uint32_t stage_count,
                                       const VkPipelineShaderStageCreateInfo *stages) {
    untranslatable_pipelines_.erase(pipeline); // a reused handle value
    for (uint32_t s = 0; s < stage_count; ++s) {
        const auto it = shader_addresses_.find(stages[s].module);
        if (it == shader_addresses_.end()) continue;
        // One layout's push-constant block may be read as addresses by one of its pipelines only;
        // the fields of all of them are translated, and a value counts as an address only when it
        // lies inside a buffer the client asked the address of (BufferAddressMap).
        auto &fields = layout_address_fields_[layout];
        fields.insert(fields.end(), it->second.push_constant_pointers.begin(),
                      it->second.push_constant_pointers.end());
        std::sort(fields.begin(), fields.end());
        fields.erase(std::unique(fields.begin(), fields.end()), fields.end());
        if (!it->second.untranslatable.empty() && !untranslatable_pipelines_.count(pipeline))
            untranslatable_pipelines_[pipeline] = it->second.untranslatable;
    }
}

bool Replayer::vkCmdPushConstants(const codec::Decoded_vkCmdPushConstants &c) {
    const auto fields = layout_address_fields_.find(c.layout);
    if (fields == layout_address_fields_.end() || !c.pValues) return ReplayVisitorBase::vkCmdPushConstants(c);
    std::vector<uint8_t> bytes(static_cast<const uint8_t *>(c.pValues),
                               static_cast<const uint8_t *>(c.pValues) + c.size);
    const PushTranslation t = translate_push_constants(addresses_, fields->second, c.offset, bytes);
    if (t.unknown || t.partial)
        guard_.untranslatable_address(
            c.commandBuffer, t.unknown ? "a push constant holds a buffer device address inside no buffer "
                                         "the client asked vkGetBufferDeviceAddress for"
                                       : "vkCmdPushConstants updates part of a buffer device address");
    auto copy = c;
    copy.pValues = bytes.data();
    return ReplayVisitorBase::vkCmdPushConstants(copy);
}

bool Replayer::buffer_address(const protocol::BufferAddress &message, std::string *error) {
    const auto *entry = table_.find(message.buffer_id);
    if (!entry || entry->type != VK_OBJECT_TYPE_BUFFER) {
        *error = "BufferAddress: unknown VkBuffer id " + hex(message.buffer_id);
        return false;
    }
    const auto buffer = codec::to_handle<VkBuffer>(entry->handle);
    const auto size = memory_.bound_buffer_size(buffer);
    if (!size) {
        *error = "BufferAddress: buffer " + hex(message.buffer_id) + " is not bound to memory";
        return false;
    }
    VkBufferDeviceAddressInfo info{};
    info.sType = VK_STRUCTURE_TYPE_BUFFER_DEVICE_ADDRESS_INFO;
    info.buffer = buffer;
    const VkDeviceAddress agent = ::vkGetBufferDeviceAddress(context_.device, &info);
    if (agent == 0) {
        *error = "BufferAddress: vkGetBufferDeviceAddress gave buffer " + hex(message.buffer_id) +
                 " no address on this GPU";
        return false;
    }
    addresses_.insert(entry->handle, message.address, *size, agent);
    return true;
}

// --- metadata -------------------------------------------------------------------------------

bool Replayer::memory_data(const protocol::MemoryData &message, std::string *error) {
    const auto *entry = table_.find(message.memory_id);
    if (!entry || entry->type != VK_OBJECT_TYPE_DEVICE_MEMORY) {
        *error = "MemoryData: unknown VkDeviceMemory id " + hex(message.memory_id);
        return false;
    }
    // Bytes for buffers go through the queue behind the work in flight (queued_writes.h); the host
    // writes what has no resource yet (the shadow) at once, and linear images after a wait.
    const auto plan = memory_.plan_write(message.memory_id, message.offset, message.bytes.size());
    QueuedWrites *queued = nullptr;
    if (gpu_busy_ && !plan.linear_images && plan.buffer_bytes > 0 &&
        plan.buffer_bytes <= QueuedWrites::kBatchBytes) {
        if (!writes_.fits(plan.buffer_bytes) && !flush_writes()) {
            *error = error_;
            return false;
        }
        queued = &writes_;
        ++memory_queued_;
    } else if (plan.buffer_bytes > 0 || plan.linear_images) {
        if (gpu_busy_) ++memory_waited_;
        quiesce(); // the bytes may land in a resource the GPU is still reading
        if (!error_.empty()) {
            *error = error_;
            return false;
        }
    }
    if (!memory_.write(message.memory_id, message.offset, message.bytes, error, queued)) {
        *error = "MemoryData: memory " + hex(message.memory_id) + ": " + *error;
        return false;
    }
    return true;
}

bool Replayer::image_layouts(const protocol::ImageLayouts &message, std::string *error) {
    const auto *entry = table_.find(message.image_id);
    if (!entry || entry->type != VK_OBJECT_TYPE_IMAGE) {
        *error = "ImageLayouts: unknown VkImage id " + hex(message.image_id);
        return false;
    }
    quiesce(); // a bound image's contents are laid out again
    std::string warning;
    if (!memory_.image_layouts(codec::to_handle<VkImage>(entry->handle), message, error, &warning)) {
        *error = "ImageLayouts: image " + hex(message.image_id) + ": " + *error;
        return false;
    }
    if (!warning.empty() && !linear_copy_logged_) {
        linear_copy_logged_ = true;
        SPLITVK_WARN("session %llu: image %s: %s", static_cast<unsigned long long>(session_id_),
                     hex(message.image_id).c_str(), warning.c_str());
    }
    return true;
}

bool Replayer::swapchain_images(const protocol::SwapchainImages &message, std::string *error) {
    std::string warning;
    if (!swapchains_.create(message, error, &warning)) {
        *error = "SwapchainImages: swapchain " + hex(message.swapchain_id) + ": " + *error;
        return false;
    }
    if (!warning.empty())
        SPLITVK_WARN("session %llu: swapchain %s: %s", static_cast<unsigned long long>(session_id_),
                     hex(message.swapchain_id).c_str(), warning.c_str());
    return true;
}

bool Replayer::swapchain_destroyed(const protocol::SwapchainDestroyed &message, std::string *error) {
    quiesce();
    if (!swapchains_.destroy(message.swapchain_id, error)) {
        *error = "SwapchainDestroyed: swapchain " + hex(message.swapchain_id) + ": " + *error;
        return false;
    }
    return true;
}

bool Replayer::swapchain_view(const protocol::SwapchainView &message, std::string *error) {
    split::RuntimeEye eye;
    eye.layer = message.array_layer;
    eye.rect = {{static_cast<int32_t>(message.x), static_cast<int32_t>(message.y)},
                {message.width, message.height}};
    eye.fov = {message.angle_left, message.angle_right, message.angle_up, message.angle_down};
    if (!swapchains_.note_eye(message.swapchain_id, eye, error)) {
        *error = "SwapchainView: swapchain " + hex(message.swapchain_id) + ": " + *error;
        return false;
    }
    return true;
}

bool Replayer::split_config(const protocol::SplitConfig &message, std::string *error) {
    if (!tile_sender_) {
        *error = "SplitConfig: this session cannot send tiles";
        return false;
    }
    if (!tiles_) tiles_ = std::make_unique<TileStreamer>(context_, tile_sender_);
    fovea_.configure(message.eyes, message.fovea, message.agent_scissor, message.moving_gaze);
    fovea_.set_enabled(!swapped_);
    tiles_->set_codec(message.codec);
    fovea_agents_ = message.fovea_agents;
    if (fovea_agents_.count > 1)
        SPLITVK_INFO("session %llu: an agent per eye: this one sends fovea %u of every %u of each image",
                     static_cast<unsigned long long>(session_id_), fovea_agents_.index + 1,
                     fovea_agents_.count);
    return true;
}

bool Replayer::periphery_config(const protocol::PeripheryConfig &message, std::string *error) {
    if (!tiles_) {
        *error = "PeripheryConfig before SplitConfig";
        return false;
    }
    if (swapped_) {
        *error = "a second PeripheryConfig";
        return false;
    }
    swapped_ = true;
    periphery_scale_ = message.scale;
    // The client renders the foveae: no pass here is cut to them (split::swapchain_pass_draw); passes
    // into window images are drawn scaled, unless the client verifies against whole frames.
    fovea_.set_enabled(false);
    scaling_.configure(message.scale, message.whole_frames);
    tiles_->set_periphery(message.quality, message.codec);
    const std::string quality = message.quality.lossless ? std::string("lossless")
                                                         : std::string(to_string(message.codec)) + " CRF " +
                                                               std::to_string(message.quality.crf);
    if (scaling_.enabled())
        SPLITVK_INFO("session %llu: the swapped split: passes into window images are drawn scaled to %.3g, "
                     "whose top-left rectangle goes back, %s",
                     static_cast<unsigned long long>(session_id_), message.scale, quality.c_str());
    else
        SPLITVK_INFO("session %llu: the swapped split: passes replay whole (the client verifies), presented "
                     "window images and released OpenXR eye images go back downsampled to %.3g, %s",
                     static_cast<unsigned long long>(session_id_), message.scale, quality.c_str());
    return true;
}

void Replayer::note_frame_submit() {
    if (frame_first_submit_ != std::chrono::steady_clock::time_point{}) return;
    frame_first_submit_ = std::chrono::steady_clock::now();
    if (tiles_) tiles_->frame_started(); // the GPU draw time starts ahead of this submit
}

bool Replayer::frame_present(const protocol::FramePresent &message,
                             std::vector<protocol::VerifyFrame> &verify, std::string *error) {
    const auto received = std::chrono::steady_clock::now();
    const bool invalid = guard_.take_frame_invalid();
    if (tiles_) {
        // Scissors recorded for the fixed foveae shaded nothing elsewhere: a fovea moved there
        // would be read back unshaded. (The swapped split scissors nothing.)
        if (!swapped_ && !message.gaze.fixed && !fovea_.moving_gaze()) {
            *error = "FramePresent " + std::to_string(message.frame) +
                     " moves the foveae, but SplitConfig said the gaze is fixed";
            return false;
        }
        // The same for a larger fovea than the one the scissors were recorded for.
        if (!swapped_ && !split::frame_fovea_size_allowed(fovea_.fovea(), message.fovea_size)) {
            *error = "FramePresent " + std::to_string(message.frame) + " asks for a fovea of " +
                     std::to_string(message.fovea_size.width) + "x" +
                     std::to_string(message.fovea_size.height) + " /" + std::to_string(split::kGazeOne) +
                     " of the eye, larger than SplitConfig's";
            return false;
        }
        // The client composites the first swapchain of a present (layer/present/present.cpp); the fovea
        // record of every presented image is taken so that none carries over to a later frame.
        for (size_t i = 0; i < message.images.size(); ++i) {
            const auto &presented = message.images[i];
            SwapchainImages::Presented image;
            if (!swapchains_.presented(presented.swapchain_id, presented.image_index, &image, error)) {
                *error = "FramePresent " + std::to_string(message.frame) + ": " + *error;
                return false;
            }
            auto foveae = fovea_.take_drawn_foveae(image.image_id, message.gaze, message.fovea_size);
            const PeripheryScaling::Frame drawn = scaling_.take_frame(image.image_id);
            if (i > 0) continue;
            TileStreamer::Frame frame;
            frame.frame = message.frame;
            frame.swapchain_id = presented.swapchain_id;
            frame.image_index = presented.image_index;
            frame.image = image.image;
            frame.layout = image.layout;
            frame.format = image.format;
            frame.extent = image.extent;
            frame.layers = image.layers;
            // An agent per eye (SPLITVK_AGENTS): only this agent's foveae are read back and sent;
            // the other eye's agent sends the rest.
            for (size_t fovea = 0; fovea < foveae.size(); ++fovea)
                if (fovea_agents_.owns(message.first_eye + fovea)) frame.foveae.push_back(foveae[fovea]);
            if (swapped_) {
                frame.foveae.clear();
                // An OpenXR eye image ends at its release, whose FramePresent this is: its periphery
                // goes back as a window's does, the whole image (both halves of a side-by-side one).
                // A layered one (multiview) the client renders whole (layer/capture/render_pass.cpp).
                if (swapchains_.runtime_image(image.image_id) && frame.layers > 1) {
                    if (!runtime_periphery_logged_)
                        SPLITVK_INFO("session %llu: the swapped split sends no periphery for layered "
                                     "OpenXR images (the client renders them whole)",
                                     static_cast<unsigned long long>(session_id_));
                    runtime_periphery_logged_ = true;
                } else {
                    frame.periphery = split::scaled_extent(frame.extent, periphery_scale_);
                    // Drawn scaled: the periphery is the image's top-left rectangle, read in place.
                    frame.periphery_in_place = drawn == PeripheryScaling::Frame::Scaled;
                }
            }
            if (invalid || drawn == PeripheryScaling::Frame::Mixed) {
                // Nothing of this frame's fovea (or periphery) is worth reading back or encoding.
                frame.foveae.clear();
                frame.periphery = {};
                frame.invalid = true;
            } else if (message.flags & protocol::kPresentNoTiles) {
                // The client takes no tiles for this frame: nothing to read back or encode.
                frame.foveae.clear();
                frame.periphery = {};
            }
            frame.first_submit = frame_first_submit_;
            frame.present = received;
            if (!tiles_->present(std::move(frame), error)) {
                *error = "FramePresent " + std::to_string(message.frame) + ": " + *error;
                return false;
            }
        }
        gpu_busy_ = true; // the fovea copy is in flight
    }
    frame_first_submit_ = {};
    if (!(message.flags & protocol::kPresentVerify)) return true;
    quiesce(); // the frame's submits complete before the images are read
    for (const auto &presented : message.images) {
        protocol::VerifyFrame frame;
        frame.frame = message.frame;
        bool unsupported = false;
        if (!swapchains_.read_back(presented.swapchain_id, presented.image_index, {}, frame, &unsupported,
                                   error)) {
            *error = "FramePresent " + std::to_string(message.frame) + ": " + *error;
            return false;
        }
        if (unsupported) {
            SwapchainImages::Presented image;
            std::string ignored;
            if (!unsupported_format_logged_ &&
                swapchains_.presented(presented.swapchain_id, presented.image_index, &image, &ignored))
                SPLITVK_WARN("session %llu: verification skips the images of %s (not a format tiles carry)",
                             static_cast<unsigned long long>(session_id_), format_name(image.format));
            unsupported_format_logged_ = true;
            continue;
        }
        verify.push_back(std::move(frame));
    }
    return true;
}

// --- the split: fovea shading (fovea_shading.h) ---------------------------------------------

bool Replayer::vkCreateImageView(const codec::Decoded_vkCreateImageView &c) {
    if (!ReplayVisitorBase::vkCreateImageView(c)) return false;
    fovea_.image_view_created(c.pView[0], *c.pCreateInfo);
    scaling_.image_view_created(c.pView[0], *c.pCreateInfo);
    return true;
}

bool Replayer::vkDestroyImageView(const codec::Decoded_vkDestroyImageView &c) {
    fovea_.image_view_destroyed(c.imageView);
    scaling_.image_view_destroyed(c.imageView);
    return ReplayVisitorBase::vkDestroyImageView(c);
}

bool Replayer::vkCreateFramebuffer(const codec::Decoded_vkCreateFramebuffer &c) {
    if (!ReplayVisitorBase::vkCreateFramebuffer(c)) return false;
    fovea_.framebuffer_created(c.pFramebuffer[0], *c.pCreateInfo);
    scaling_.framebuffer_created(c.pFramebuffer[0], *c.pCreateInfo);
    return true;
}

bool Replayer::vkDestroyFramebuffer(const codec::Decoded_vkDestroyFramebuffer &c) {
    fovea_.framebuffer_destroyed(c.framebuffer);
    scaling_.framebuffer_destroyed(c.framebuffer);
    return ReplayVisitorBase::vkDestroyFramebuffer(c);
}

bool Replayer::vkDestroyPipeline(const codec::Decoded_vkDestroyPipeline &c) {
    fovea_.pipeline_destroyed(c.pipeline);
    scaling_.pipeline_destroyed(c.pipeline);
    untranslatable_pipelines_.erase(c.pipeline);
    return ReplayVisitorBase::vkDestroyPipeline(c);
}

bool Replayer::vkBeginCommandBuffer(const codec::Decoded_vkBeginCommandBuffer &c) {
    // A new recording: the previous one's stream and variants are gone (not for a variant's own
    // begin, which names the secondary's id).
    if (!recording_variant_) forget_secondary(c.commandBuffer_id);
    if (!ReplayVisitorBase::vkBeginCommandBuffer(c)) return false;
    fovea_.begin_command_buffer(c.commandBuffer, c.pBeginInfo);
    scaling_.begin_command_buffer(c.commandBuffer, c.pBeginInfo);
    guard_.command_buffer_begun(c.commandBuffer);
    return true;
}

bool Replayer::vkFreeCommandBuffers(const codec::Decoded_vkFreeCommandBuffers &c) {
    for (uint32_t i = 0; c.pCommandBuffers_ids && i < c.commandBufferCount; ++i)
        forget_secondary(c.pCommandBuffers_ids[i]);
    return ReplayVisitorBase::vkFreeCommandBuffers(c);
}

bool Replayer::vkDestroyCommandPool(const codec::Decoded_vkDestroyCommandPool &c) {
    std::vector<uint64_t> freed; // the pool's command buffers, while the table still names their pool
    for (const auto &[id, secondary] : secondaries_)
        if (const auto *entry = table_.find(id); !entry || entry->parent == c.commandPool_id)
            freed.push_back(id);
    for (uint64_t id : freed)
        forget_secondary(id);
    return ReplayVisitorBase::vkDestroyCommandPool(c);
}

// --- secondaries in scissored passes (fovea_shading.h) ---------------------------------------

void Replayer::keep_secondary_stream(uint64_t id, std::span<const uint8_t> stream) {
    // What a session may keep: the client's streams are not charged to --max-host-memory, and an
    // application's secondaries are small next to this; past it, the rest are shaded whole.
    constexpr uint64_t kMaxKeptBytes = 64ull << 20;
    const auto *entry = table_.find(id);
    if (recording_variant_ || !entry) return;
    const auto secondary = codec::to_handle<VkCommandBuffer>(entry->handle);
    if (!fovea_.continues_pass(secondary) && !scaling_.continues_pass(secondary)) return;
    if (kept_stream_bytes_ + stream.size() > kMaxKeptBytes) {
        if (!variant_failed_logged_)
            SPLITVK_WARN(
                "secondaries in scissored passes: their commands pass %llu MiB; the rest are shaded whole",
                static_cast<unsigned long long>(kMaxKeptBytes >> 20));
        variant_failed_logged_ = true;
        return;
    }
    SecondaryStream &kept = secondaries_[id];
    kept_stream_bytes_ += stream.size() - kept.stream.size();
    kept.stream.assign(stream.begin(), stream.end());
}

void Replayer::forget_secondary(uint64_t id) {
    const auto it = secondaries_.find(id);
    if (it == secondaries_.end()) return;
    if (!it->second.variants.empty()) {
        quiesce(); // a no-op: the queue is idle when a secondary is re-begun or freed (SecondaryStream)
        for (const auto &[scissor, variant] : it->second.variants)
            ::vkFreeCommandBuffers(context_.device, variant_pool_, 1, &variant);
    }
    kept_stream_bytes_ -= it->second.stream.size();
    secondaries_.erase(it);
}

VkCommandBuffer Replayer::secondary_variant(uint64_t id, VkCommandBuffer secondary,
                                            const FoveaShading::PassScissor &scissor) {
    const auto it = secondaries_.find(id);
    const auto *entry = table_.find(id);
    if (it == secondaries_.end() || it->second.stream.empty() || !entry ||
        entry->handle != codec::handle_value(secondary))
        return VK_NULL_HANDLE;
    for (const auto &[recorded_for, variant] : it->second.variants)
        if (recorded_for.same_as(scissor)) return variant;
    const auto give_up = [&](const char *why) {
        if (!variant_failed_logged_)
            SPLITVK_WARN("secondaries in scissored passes: %s; they are shaded whole", why);
        variant_failed_logged_ = true;
        return VK_NULL_HANDLE;
    };
    if (!variant_pool_) {
        VkCommandPoolCreateInfo info{};
        info.sType = VK_STRUCTURE_TYPE_COMMAND_POOL_CREATE_INFO;
        info.queueFamilyIndex = context_.queue_family;
        if (::vkCreateCommandPool(context_.device, &info, nullptr, &variant_pool_) != VK_SUCCESS) {
            variant_pool_ = VK_NULL_HANDLE;
            return give_up("no command pool");
        }
    }
    VkCommandBufferAllocateInfo allocate{};
    allocate.sType = VK_STRUCTURE_TYPE_COMMAND_BUFFER_ALLOCATE_INFO;
    allocate.commandPool = variant_pool_;
    allocate.level = VK_COMMAND_BUFFER_LEVEL_SECONDARY;
    allocate.commandBufferCount = 1;
    VkCommandBuffer variant = VK_NULL_HANDLE;
    if (::vkAllocateCommandBuffers(context_.device, &allocate, &variant) != VK_SUCCESS)
        return give_up("no command buffer");
    // The stream names the secondary by its client id: for its second recording, that id names
    // the variant. Nothing else is decoded meanwhile (the primary's command is already decoded).
    const codec::HandleTable::Entry original = *entry;
    table_.remove(id);
    table_.insert(id, original.type, codec::handle_value(variant), original.parent);
    if (scissor.scaled)
        scaling_.begin_variant(variant, scissor.image, scissor.extent);
    else
        fovea_.begin_variant(variant, scissor);
    const std::string first_error = error_;
    recording_variant_ = true;
    codec::Decoder d(it->second.stream, table_, variant_arena_);
    bool ok = true;
    while (ok && d.ok() && !d.at_end())
        ok = codec::dispatch_decoded(d, *this);
    ok = ok && d.ok();
    recording_variant_ = false;
    const std::string error = !d.ok() ? d.error() : error_;
    error_ = first_error; // the stream replayed once already: a failure here is not the session's
    variant_arena_.reset();
    table_.remove(id);
    table_.insert(id, original.type, original.handle, original.parent);
    if (!ok) {
        ::vkFreeCommandBuffers(context_.device, variant_pool_, 1, &variant);
        return give_up(error.c_str());
    }
    it->second.variants.emplace_back(scissor, variant);
    return variant;
}

namespace {

// What prescan_transfer_reads decodes the recording with: the swapchain images that transfers of
// one command buffer read, up to its vkEndCommandBuffer. Everything else is decoded and skipped.
class TransferReads final : public codec::CommandVisitor {
public:
    TransferReads(uint64_t command_buffer, const SwapchainImages &swapchains, const FoveaShading &fovea)
        : command_buffer_(command_buffer), swapchains_(swapchains), fovea_(fovea) {}

    bool ended() const { return ended_; }
    std::vector<uint64_t> take() { return std::move(images_); }

    bool unhandled(codec::VkCommandId) override { return true; }
    bool vkEndCommandBuffer(const codec::Decoded_vkEndCommandBuffer &c) override {
        ended_ |= c.commandBuffer_id == command_buffer_;
        return true;
    }
    bool vkCmdCopyImage(const codec::Decoded_vkCmdCopyImage &c) override {
        return read(c.commandBuffer_id, c.srcImage);
    }
    bool vkCmdCopyImage2(const codec::Decoded_vkCmdCopyImage2 &c) override {
        return read(c.commandBuffer_id, c.pCopyImageInfo ? c.pCopyImageInfo->srcImage : VK_NULL_HANDLE);
    }
    bool vkCmdBlitImage(const codec::Decoded_vkCmdBlitImage &c) override {
        return read(c.commandBuffer_id, c.srcImage);
    }
    bool vkCmdBlitImage2(const codec::Decoded_vkCmdBlitImage2 &c) override {
        return read(c.commandBuffer_id, c.pBlitImageInfo ? c.pBlitImageInfo->srcImage : VK_NULL_HANDLE);
    }
    bool vkCmdResolveImage(const codec::Decoded_vkCmdResolveImage &c) override {
        return read(c.commandBuffer_id, c.srcImage);
    }
    bool vkCmdResolveImage2(const codec::Decoded_vkCmdResolveImage2 &c) override {
        return read(c.commandBuffer_id, c.pResolveImageInfo ? c.pResolveImageInfo->srcImage : VK_NULL_HANDLE);
    }
    bool vkCmdCopyImageToBuffer(const codec::Decoded_vkCmdCopyImageToBuffer &c) override {
        return read(c.commandBuffer_id, c.srcImage);
    }
    bool vkCmdCopyImageToBuffer2(const codec::Decoded_vkCmdCopyImageToBuffer2 &c) override {
        return read(c.commandBuffer_id,
                    c.pCopyImageToBufferInfo ? c.pCopyImageToBufferInfo->srcImage : VK_NULL_HANDLE);
    }
    // Secondaries are recorded before the primaries that execute them: their own prescan said
    // what they read. (A secondary's own split passes were recorded before this primary's copy
    // was known: they keep their scissors.)
    bool vkCmdExecuteCommands(const codec::Decoded_vkCmdExecuteCommands &c) override {
        if (c.commandBuffer_id != command_buffer_ || !c.pCommandBuffers) return true;
        for (uint32_t i = 0; i < c.commandBufferCount; ++i)
            for (uint64_t image : fovea_.transfer_reads(c.pCommandBuffers[i]))
                add(image);
        return true;
    }

private:
    bool read(uint64_t command_buffer, VkImage image) {
        uint64_t image_id = 0;
        VkExtent2D extent{};
        if (command_buffer == command_buffer_ && image && swapchains_.find_image(image, &image_id, &extent))
            add(image_id);
        return true;
    }
    void add(uint64_t image_id) {
        if (std::find(images_.begin(), images_.end(), image_id) == images_.end()) images_.push_back(image_id);
    }

    uint64_t command_buffer_;
    const SwapchainImages &swapchains_;
    const FoveaShading &fovea_;
    std::vector<uint64_t> images_;
    bool ended_ = false;
};

} // namespace

void Replayer::prescan_transfer_reads(std::span<const uint8_t> payload, size_t offset, uint64_t id,
                                      VkCommandBuffer command_buffer) {
    if (!fovea_.enabled()) return;
    TransferReads reads(id, swapchains_, fovea_);
    // A decoding error is the replay's to report, when it reaches it; what was read until then counts.
    codec::Decoder d(payload.subspan(offset), table_, prescan_arena_);
    while (d.ok() && !d.at_end() && !reads.ended())
        if (!codec::dispatch_decoded(d, reads)) break;
    prescan_arena_.reset();
    fovea_.note_transfer_reads(command_buffer, reads.take());
}

// --- the limit guard (limit_guard.h) ---------------------------------------------------------

bool Replayer::vkUpdateDescriptorSets(const codec::Decoded_vkUpdateDescriptorSets &c) {
    std::vector<VkWriteDescriptorSet> writes;
    std::vector<VkDescriptorBufferInfo> buffer_infos;
    auto checked = c;
    checked.pDescriptorWrites =
        guard_.descriptor_writes(c.descriptorWriteCount, c.pDescriptorWrites, writes, buffer_infos);
    guard_.descriptor_copies(c.descriptorCopyCount, c.pDescriptorCopies);
    return ReplayVisitorBase::vkUpdateDescriptorSets(checked);
}

bool Replayer::vkFreeDescriptorSets(const codec::Decoded_vkFreeDescriptorSets &c) {
    guard_.descriptor_sets_freed(c.descriptorSetCount, c.pDescriptorSets);
    return ReplayVisitorBase::vkFreeDescriptorSets(c);
}

bool Replayer::vkCmdBindDescriptorSets(const codec::Decoded_vkCmdBindDescriptorSets &c) {
    if (!ReplayVisitorBase::vkCmdBindDescriptorSets(c)) return false;
    guard_.sets_bound(c.commandBuffer, c.descriptorSetCount, c.pDescriptorSets, c.dynamicOffsetCount,
                      c.pDynamicOffsets);
    return true;
}

namespace {

VkRect2D blit_rect(const VkOffset3D corners[2]) {
    const int32_t x0 = std::min(corners[0].x, corners[1].x), y0 = std::min(corners[0].y, corners[1].y);
    return {{x0, y0},
            {static_cast<uint32_t>(std::max(corners[0].x, corners[1].x) - x0),
             static_cast<uint32_t>(std::max(corners[0].y, corners[1].y) - y0)}};
}

template <class Region>
std::vector<VkRect2D> copy_rects(uint32_t count, const Region *regions) {
    std::vector<VkRect2D> rects;
    for (uint32_t i = 0; i < count; ++i)
        rects.push_back({{regions[i].dstOffset.x, regions[i].dstOffset.y},
                         {regions[i].extent.width, regions[i].extent.height}});
    return rects;
}

template <class Region>
std::vector<VkRect2D> blit_rects(uint32_t count, const Region *regions) {
    std::vector<VkRect2D> rects;
    for (uint32_t i = 0; i < count; ++i)
        rects.push_back(blit_rect(regions[i].dstOffsets));
    return rects;
}

} // namespace

bool Replayer::vkCmdBlitImage(const codec::Decoded_vkCmdBlitImage &c) {
    std::vector<VkImageBlit> scaled(c.pRegions, c.pRegions + c.regionCount);
    std::vector<std::array<VkOffset3D, 2>> offsets(c.regionCount);
    for (uint32_t i = 0; i < c.regionCount; ++i)
        std::copy_n(scaled[i].dstOffsets, 2, offsets[i].begin());
    codec::Decoded_vkCmdBlitImage local = c;
    if (scaling_.scale_blit(c.commandBuffer, c.dstImage, c.regionCount, offsets.data())) {
        for (uint32_t i = 0; i < c.regionCount; ++i)
            std::copy_n(offsets[i].begin(), 2, scaled[i].dstOffsets);
        local.pRegions = scaled.data();
    }
    if (!ReplayVisitorBase::vkCmdBlitImage(local)) return false;
    const auto rects = blit_rects(c.regionCount, c.pRegions);
    fovea_.transfer_into(c.commandBuffer, c.dstImage, static_cast<uint32_t>(rects.size()), rects.data());
    return true;
}

bool Replayer::vkCmdBlitImage2(const codec::Decoded_vkCmdBlitImage2 &c) {
    const VkBlitImageInfo2 &info = *c.pBlitImageInfo;
    std::vector<VkImageBlit2> scaled(info.pRegions, info.pRegions + info.regionCount);
    std::vector<std::array<VkOffset3D, 2>> offsets(info.regionCount);
    for (uint32_t i = 0; i < info.regionCount; ++i)
        std::copy_n(scaled[i].dstOffsets, 2, offsets[i].begin());
    VkBlitImageInfo2 local_info = info;
    codec::Decoded_vkCmdBlitImage2 local = c;
    if (scaling_.scale_blit(c.commandBuffer, info.dstImage, info.regionCount, offsets.data())) {
        for (uint32_t i = 0; i < info.regionCount; ++i)
            std::copy_n(offsets[i].begin(), 2, scaled[i].dstOffsets);
        local_info.pRegions = scaled.data();
        local.pBlitImageInfo = &local_info;
    }
    if (!ReplayVisitorBase::vkCmdBlitImage2(local)) return false;
    const auto rects = blit_rects(c.pBlitImageInfo->regionCount, c.pBlitImageInfo->pRegions);
    fovea_.transfer_into(c.commandBuffer, c.pBlitImageInfo->dstImage, static_cast<uint32_t>(rects.size()),
                         rects.data());
    return true;
}

bool Replayer::vkCmdCopyImage(const codec::Decoded_vkCmdCopyImage &c) {
    if (!ReplayVisitorBase::vkCmdCopyImage(c)) return false;
    scaling_.whole_write(c.commandBuffer, c.dstImage);
    const auto rects = copy_rects(c.regionCount, c.pRegions);
    fovea_.transfer_into(c.commandBuffer, c.dstImage, static_cast<uint32_t>(rects.size()), rects.data());
    return true;
}

bool Replayer::vkCmdCopyImage2(const codec::Decoded_vkCmdCopyImage2 &c) {
    if (!ReplayVisitorBase::vkCmdCopyImage2(c)) return false;
    scaling_.whole_write(c.commandBuffer, c.pCopyImageInfo->dstImage);
    const auto rects = copy_rects(c.pCopyImageInfo->regionCount, c.pCopyImageInfo->pRegions);
    fovea_.transfer_into(c.commandBuffer, c.pCopyImageInfo->dstImage, static_cast<uint32_t>(rects.size()),
                         rects.data());
    return true;
}

bool Replayer::vkCmdResolveImage(const codec::Decoded_vkCmdResolveImage &c) {
    if (!ReplayVisitorBase::vkCmdResolveImage(c)) return false;
    scaling_.whole_write(c.commandBuffer, c.dstImage);
    const auto rects = copy_rects(c.regionCount, c.pRegions);
    fovea_.transfer_into(c.commandBuffer, c.dstImage, static_cast<uint32_t>(rects.size()), rects.data());
    return true;
}

bool Replayer::vkCmdResolveImage2(const codec::Decoded_vkCmdResolveImage2 &c) {
    if (!ReplayVisitorBase::vkCmdResolveImage2(c)) return false;
    scaling_.whole_write(c.commandBuffer, c.pResolveImageInfo->dstImage);
    const auto rects = copy_rects(c.pResolveImageInfo->regionCount, c.pResolveImageInfo->pRegions);
    fovea_.transfer_into(c.commandBuffer, c.pResolveImageInfo->dstImage, static_cast<uint32_t>(rects.size()),
                         rects.data());
    return true;
}

bool Replayer::vkCmdExecuteCommands(const codec::Decoded_vkCmdExecuteCommands &c) {
    // In a scissored pass, each secondary's variant for it; the secondaries themselves still say
    // which foveae were drawn. A variant's own secondaries (nested command buffers) run as recorded:
    // recording one variant inside another would reuse the arena the outer one is decoded from.
    std::vector<VkCommandBuffer> executed;
    auto scissor = recording_variant_ ? std::nullopt : fovea_.pass_scissor(c.commandBuffer);
    if (!scissor && !recording_variant_) scissor = scaling_.pass_variant(c.commandBuffer);
    if (scissor && c.pCommandBuffers_ids) {
        executed.assign(c.pCommandBuffers, c.pCommandBuffers + c.commandBufferCount);
        for (uint32_t i = 0; i < c.commandBufferCount; ++i)
            if (const VkCommandBuffer variant =
                    secondary_variant(c.pCommandBuffers_ids[i], c.pCommandBuffers[i], *scissor))
                executed[i] = variant;
            else if (scissor->scaled)
                scaling_.unscaled_secondary(c.commandBuffer); // drawn at full size into a scaled pass
    } else if (scissor && scissor->scaled) {
        scaling_.unscaled_secondary(c.commandBuffer);
    }
    codec::Decoded_vkCmdExecuteCommands local = c;
    if (!executed.empty()) local.pCommandBuffers = executed.data();
    if (!ReplayVisitorBase::vkCmdExecuteCommands(local)) return false;
    fovea_.execute_commands(c.commandBuffer, c.commandBufferCount, c.pCommandBuffers);
    scaling_.execute_commands(c.commandBuffer, c.commandBufferCount, c.pCommandBuffers);
    guard_.executed(c.commandBuffer, c.commandBufferCount, c.pCommandBuffers);
    return true;
}

bool Replayer::vkCmdPipelineBarrier(const codec::Decoded_vkCmdPipelineBarrier &c) {
    const auto buffers =
        codec::with_local_queue_families(c.pBufferMemoryBarriers, c.bufferMemoryBarrierCount);
    const auto images = codec::with_local_queue_families(c.pImageMemoryBarriers, c.imageMemoryBarrierCount);
    if (buffers.empty() && images.empty()) return ReplayVisitorBase::vkCmdPipelineBarrier(c);
    codec::Decoded_vkCmdPipelineBarrier local = c;
    if (!buffers.empty()) local.pBufferMemoryBarriers = buffers.data();
    if (!images.empty()) local.pImageMemoryBarriers = images.data();
    return ReplayVisitorBase::vkCmdPipelineBarrier(local);
}

bool Replayer::vkCmdPipelineBarrier2(const codec::Decoded_vkCmdPipelineBarrier2 &c) {
    if (!c.pDependencyInfo) return ReplayVisitorBase::vkCmdPipelineBarrier2(c);
    const VkDependencyInfo &dependency = *c.pDependencyInfo;
    const auto buffers = codec::with_local_queue_families(dependency.pBufferMemoryBarriers,
                                                          dependency.bufferMemoryBarrierCount);
    const auto images =
        codec::with_local_queue_families(dependency.pImageMemoryBarriers, dependency.imageMemoryBarrierCount);
    if (buffers.empty() && images.empty()) return ReplayVisitorBase::vkCmdPipelineBarrier2(c);
    VkDependencyInfo local_dependency = dependency;
    if (!buffers.empty()) local_dependency.pBufferMemoryBarriers = buffers.data();
    if (!images.empty()) local_dependency.pImageMemoryBarriers = images.data();
    codec::Decoded_vkCmdPipelineBarrier2 local = c;
    local.pDependencyInfo = &local_dependency;
    return ReplayVisitorBase::vkCmdPipelineBarrier2(local);
}

bool Replayer::vkCmdBindPipeline(const codec::Decoded_vkCmdBindPipeline &c) {
    if (!ReplayVisitorBase::vkCmdBindPipeline(c)) return false;
    fovea_.bind_pipeline(c.commandBuffer, c.pipelineBindPoint, c.pipeline);
    scaling_.bind_pipeline(c.commandBuffer, c.pipelineBindPoint, c.pipeline);
    if (const auto it = untranslatable_pipelines_.find(c.pipeline); it != untranslatable_pipelines_.end())
        guard_.untranslatable_address(c.commandBuffer, "a pipeline's shaders use " + it->second);
    return true;
}

bool Replayer::vkCmdSetViewport(const codec::Decoded_vkCmdSetViewport &c) {
    if (!ReplayVisitorBase::vkCmdSetViewport(c)) return false;
    fovea_.set_viewports(c.commandBuffer, c.firstViewport, c.viewportCount, c.pViewports, false);
    scaling_.set_viewports(c.commandBuffer, c.firstViewport, c.viewportCount, c.pViewports, false);
    return true;
}

bool Replayer::vkCmdSetViewportWithCount(const codec::Decoded_vkCmdSetViewportWithCount &c) {
    if (!ReplayVisitorBase::vkCmdSetViewportWithCount(c)) return false;
    fovea_.set_viewports(c.commandBuffer, 0, c.viewportCount, c.pViewports, true);
    scaling_.set_viewports(c.commandBuffer, 0, c.viewportCount, c.pViewports, true);
    return true;
}

bool Replayer::vkCmdSetScissor(const codec::Decoded_vkCmdSetScissor &c) {
    if (!vk.CmdSetScissor) return missing("vkCmdSetScissor");
    fovea_.set_scissors(c.commandBuffer, c.firstScissor, c.scissorCount, c.pScissors, false);
    scaling_.set_scissors(c.commandBuffer, c.firstScissor, c.scissorCount, c.pScissors, false);
    return true;
}

bool Replayer::vkCmdSetScissorWithCount(const codec::Decoded_vkCmdSetScissorWithCount &c) {
    if (!vk.CmdSetScissorWithCount) return missing("vkCmdSetScissorWithCount");
    fovea_.set_scissors(c.commandBuffer, 0, c.scissorCount, c.pScissors, true);
    scaling_.set_scissors(c.commandBuffer, 0, c.scissorCount, c.pScissors, true);
    return true;
}

bool Replayer::vkCmdBeginRenderPass(const codec::Decoded_vkCmdBeginRenderPass &c) {
    VkRenderPassBeginInfo begin = *c.pRenderPassBegin;
    codec::Decoded_vkCmdBeginRenderPass local = c;
    if (const auto area =
            scaling_.begin_render_pass(c.commandBuffer, begin, c.contents != VK_SUBPASS_CONTENTS_INLINE)) {
        begin.renderArea = *area;
        local.pRenderPassBegin = &begin;
    }
    if (!ReplayVisitorBase::vkCmdBeginRenderPass(local)) return false;
    fovea_.begin_render_pass(c.commandBuffer, *c.pRenderPassBegin, c.contents != VK_SUBPASS_CONTENTS_INLINE);
    return true;
}

bool Replayer::vkCmdBeginRenderPass2(const codec::Decoded_vkCmdBeginRenderPass2 &c) {
    VkRenderPassBeginInfo begin = *c.pRenderPassBegin;
    codec::Decoded_vkCmdBeginRenderPass2 local = c;
    if (const auto area = scaling_.begin_render_pass(
            c.commandBuffer, begin, c.pSubpassBeginInfo->contents != VK_SUBPASS_CONTENTS_INLINE)) {
        begin.renderArea = *area;
        local.pRenderPassBegin = &begin;
    }
    if (!ReplayVisitorBase::vkCmdBeginRenderPass2(local)) return false;
    fovea_.begin_render_pass(c.commandBuffer, *c.pRenderPassBegin,
                             c.pSubpassBeginInfo->contents != VK_SUBPASS_CONTENTS_INLINE);
    return true;
}

bool Replayer::vkCmdBeginRendering(const codec::Decoded_vkCmdBeginRendering &c) {
    VkRenderingInfo info = *c.pRenderingInfo;
    codec::Decoded_vkCmdBeginRendering local = c;
    if (const auto area = scaling_.begin_rendering(c.commandBuffer, info)) {
        info.renderArea = *area;
        local.pRenderingInfo = &info;
    }
    if (!ReplayVisitorBase::vkCmdBeginRendering(local)) return false;
    fovea_.begin_rendering(c.commandBuffer, *c.pRenderingInfo);
    return true;
}

bool Replayer::vkCmdEndRenderPass(const codec::Decoded_vkCmdEndRenderPass &c) {
    if (!ReplayVisitorBase::vkCmdEndRenderPass(c)) return false;
    fovea_.end_pass(c.commandBuffer);
    scaling_.end_pass(c.commandBuffer);
    return true;
}

bool Replayer::vkCmdEndRenderPass2(const codec::Decoded_vkCmdEndRenderPass2 &c) {
    if (!ReplayVisitorBase::vkCmdEndRenderPass2(c)) return false;
    fovea_.end_pass(c.commandBuffer);
    scaling_.end_pass(c.commandBuffer);
    return true;
}

bool Replayer::vkCmdClearAttachments(const codec::Decoded_vkCmdClearAttachments &c) {
    const auto rects = scaling_.clear_rects(c.commandBuffer, c.rectCount, c.pRects);
    if (!rects) return ReplayVisitorBase::vkCmdClearAttachments(c);
    if (rects->empty()) return true; // clamped away: nothing of it lies in the periphery
    codec::Decoded_vkCmdClearAttachments local = c;
    local.rectCount = static_cast<uint32_t>(rects->size());
    local.pRects = rects->data();
    return ReplayVisitorBase::vkCmdClearAttachments(local);
}

bool Replayer::vkCmdEndRendering(const codec::Decoded_vkCmdEndRendering &c) {
    if (!ReplayVisitorBase::vkCmdEndRendering(c)) return false;
    fovea_.end_pass(c.commandBuffer);
    scaling_.end_pass(c.commandBuffer);
    return true;
}

} // namespace splitvk::agent
