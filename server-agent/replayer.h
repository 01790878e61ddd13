#pragma once

// A session's replay of the client's command stream on the agent's own GPU (docs/architecture.md §2-3).
// The generated ReplayVisitorBase (codegen/emit_replay.py) replays forwarded commands as they are;
// this class overrides what has real semantics: the device and its queue, submits (in order on one
// queue, without the client's semaphores and fences), memory (memory_rebind.h), pipelines (no
// pipeline cache), and the metadata messages (memory data, swapchains, frame marks).

#include "buffer_addresses.h"
#include "fovea_shading.h"
#include "limit_guard.h"
#include "memory_rebind.h"
#include "metadata.h"
#include "periphery_scaling.h"
#include "queued_writes.h"
#include "spirv_pointers.h"
#include "swapchain_images.h"
#include "tile_streamer.h"
#include "vk_codec.h"
#include "vk_replay.h"
#include "vulkan_context.h"

#include <chrono>
#include <cstdint>
#include <deque>
#include <memory>
#include <span>
#include <string>
#include <unordered_map>
#include <unordered_set>
#include <vector>

namespace splitvk::agent {

class Replayer final : public ReplayVisitorBase {
public:
    // `limits`: the session's --max-host-memory / --max-gpu-memory caps (memory_rebind.h).
    // `device`: the agent's GPU as clients are told it is (--emulate-limits included), what the
    // limit guard holds replayed commands to.
    Replayer(uint64_t session_id, const MemoryLimits &limits, protocol::DeviceDescription device);
    ~Replayer() override;

    // The session's instance on GPU `device_index`; false with one line in `error`.
    bool init(uint32_t device_index, bool validate, std::string *error);
    const VulkanContext &context() const { return context_; }

    // Replays one Commands payload. False with one line in `error` ("vkCmdDraw: unknown
    // VkCommandBuffer id 0x777 at offset 2"); the session then ends.
    bool replay(std::span<const uint8_t> payload, std::string *error);
    bool memory_data(const protocol::MemoryData &message, std::string *error);
    bool swapchain_images(const protocol::SwapchainImages &message, std::string *error);
    bool swapchain_destroyed(const protocol::SwapchainDestroyed &message, std::string *error);
    bool swapchain_view(const protocol::SwapchainView &message, std::string *error);
    // The client's layout of a linear image, for MemoryData into it (memory_rebind.h).
    bool image_layouts(const protocol::ImageLayouts &message, std::string *error);
    // The client's address of a bound buffer, mapped to the agent's own (buffer_addresses.h).
    bool buffer_address(const protocol::BufferAddress &message, std::string *error);
    // FramePresent: hands the first presented image's fovea to the tile streamer (when tiles are
    // enabled); with kPresentVerify, also waits for the frame's work and reads each image back (in
    // the swapped split too: its passes replay whole, so that is the native frame, which the client
    // compares its foveae and its periphery with).
    bool frame_present(const protocol::FramePresent &message, std::vector<protocol::VerifyFrame> &verify,
                       std::string *error);
    // Where Tiles messages go. Tiles start with SplitConfig: the client sends it only when it
    // splits, and until then the agent neither restricts shading to the fovea nor sends tiles.
    void set_tile_sender(TileStreamer::Send send) { tile_sender_ = std::move(send); }
    bool split_config(const protocol::SplitConfig &message, std::string *error);
    // The swapped split (the session checked capability kSwappedSplit): after SplitConfig,
    // every pass replays whole (no fovea shading) and each presented window image goes back
    // downsampled to the config's scale as periphery tiles. False with one line in `error` before
    // SplitConfig or a second time.
    bool periphery_config(const protocol::PeripheryConfig &message, std::string *error);

    // Split passes shaded in the foveae only (fovea_shading.h).
    FoveaShading &fovea() { return fovea_; }
    // The swapped split's passes drawn scaled (periphery_scaling.h).
    PeripheryScaling &scaling() { return scaling_; }

    uint64_t commands_replayed() const { return commands_; }
    uint64_t submits() const { return submits_; }
    // MemoryData while the GPU was busy: queued behind its work, or written after waiting for it.
    uint64_t memory_queued() const { return memory_queued_; }
    uint64_t memory_waited() const { return memory_waited_; }

    bool failed(const char *command, VkResult result, const std::string &detail = {}) override;
    bool unhandled(codec::VkCommandId id) override;

    bool vkCreateInstance(const codec::Decoded_vkCreateInstance &c) override;
    bool vkDestroyInstance(const codec::Decoded_vkDestroyInstance &c) override;
    bool vkCreateDevice(const codec::Decoded_vkCreateDevice &c) override;
    bool vkDestroyDevice(const codec::Decoded_vkDestroyDevice &c) override;
    bool vkGetDeviceQueue(const codec::Decoded_vkGetDeviceQueue &c) override;
    bool vkGetDeviceQueue2(const codec::Decoded_vkGetDeviceQueue2 &c) override;
    bool vkQueueSubmit(const codec::Decoded_vkQueueSubmit &c) override;
    bool vkQueueSubmit2(const codec::Decoded_vkQueueSubmit2 &c) override;
    bool vkAllocateCommandBuffers(const codec::Decoded_vkAllocateCommandBuffers &c) override;
    bool vkAllocateMemory(const codec::Decoded_vkAllocateMemory &c) override;
    bool vkFreeMemory(const codec::Decoded_vkFreeMemory &c) override;
    bool vkMapMemory(const codec::Decoded_vkMapMemory &c) override;
    bool vkUnmapMemory(const codec::Decoded_vkUnmapMemory &c) override;
    bool vkFlushMappedMemoryRanges(const codec::Decoded_vkFlushMappedMemoryRanges &c) override;
    bool vkInvalidateMappedMemoryRanges(const codec::Decoded_vkInvalidateMappedMemoryRanges &c) override;
    bool vkResetFences(const codec::Decoded_vkResetFences &c) override;
    bool vkBindBufferMemory(const codec::Decoded_vkBindBufferMemory &c) override;
    bool vkBindBufferMemory2(const codec::Decoded_vkBindBufferMemory2 &c) override;
    bool vkBindImageMemory(const codec::Decoded_vkBindImageMemory &c) override;
    bool vkBindImageMemory2(const codec::Decoded_vkBindImageMemory2 &c) override;
    bool vkCreateBuffer(const codec::Decoded_vkCreateBuffer &c) override;
    bool vkDestroyBuffer(const codec::Decoded_vkDestroyBuffer &c) override;
    bool vkCreateImage(const codec::Decoded_vkCreateImage &c) override;
    bool vkDestroyImage(const codec::Decoded_vkDestroyImage &c) override;
    bool vkCreateGraphicsPipelines(const codec::Decoded_vkCreateGraphicsPipelines &c) override;

    // The limit guard (limit_guard.h): what this GPU cannot honour marks the frames that use it.
    bool vkUpdateDescriptorSets(const codec::Decoded_vkUpdateDescriptorSets &c) override;
    bool vkFreeDescriptorSets(const codec::Decoded_vkFreeDescriptorSets &c) override;
    bool vkCmdBindDescriptorSets(const codec::Decoded_vkCmdBindDescriptorSets &c) override;
    bool vkCreateComputePipelines(const codec::Decoded_vkCreateComputePipelines &c) override;

    // Ownership transfers to and from an OpenXR runtime's process, replayed as local barriers
    // (codec::with_local_queue_families).
    bool vkCmdPipelineBarrier(const codec::Decoded_vkCmdPipelineBarrier &c) override;
    bool vkCmdPipelineBarrier2(const codec::Decoded_vkCmdPipelineBarrier2 &c) override;

    // Buffer device addresses (buffer_addresses.h): which push-constant bytes each pipeline layout's
    // shaders read as addresses, translated at vkCmdPushConstants; pipelines that get addresses the
    // agent cannot translate taint the command buffers that bind them (limit_guard.h).
    bool vkCreateShaderModule(const codec::Decoded_vkCreateShaderModule &c) override;
    bool vkDestroyShaderModule(const codec::Decoded_vkDestroyShaderModule &c) override;
    bool vkDestroyPipelineLayout(const codec::Decoded_vkDestroyPipelineLayout &c) override;
    bool vkCmdPushConstants(const codec::Decoded_vkCmdPushConstants &c) override;

    // The split (fovea_shading.h): what makes a split pass, and the scissors narrowed inside one.
    bool vkCreateImageView(const codec::Decoded_vkCreateImageView &c) override;
    bool vkDestroyImageView(const codec::Decoded_vkDestroyImageView &c) override;
    bool vkCreateFramebuffer(const codec::Decoded_vkCreateFramebuffer &c) override;
    bool vkDestroyFramebuffer(const codec::Decoded_vkDestroyFramebuffer &c) override;
    bool vkDestroyPipeline(const codec::Decoded_vkDestroyPipeline &c) override;
    bool vkBeginCommandBuffer(const codec::Decoded_vkBeginCommandBuffer &c) override;
    bool vkFreeCommandBuffers(const codec::Decoded_vkFreeCommandBuffers &c) override;
    bool vkDestroyCommandPool(const codec::Decoded_vkDestroyCommandPool &c) override;
    bool vkCmdBindPipeline(const codec::Decoded_vkCmdBindPipeline &c) override;
    bool vkCmdBlitImage(const codec::Decoded_vkCmdBlitImage &c) override;
    bool vkCmdBlitImage2(const codec::Decoded_vkCmdBlitImage2 &c) override;
    bool vkCmdCopyImage(const codec::Decoded_vkCmdCopyImage &c) override;
    bool vkCmdCopyImage2(const codec::Decoded_vkCmdCopyImage2 &c) override;
    bool vkCmdExecuteCommands(const codec::Decoded_vkCmdExecuteCommands &c) override;
    bool vkCmdResolveImage(const codec::Decoded_vkCmdResolveImage &c) override;
    bool vkCmdResolveImage2(const codec::Decoded_vkCmdResolveImage2 &c) override;
    bool vkCmdSetViewport(const codec::Decoded_vkCmdSetViewport &c) override;
    bool vkCmdSetViewportWithCount(const codec::Decoded_vkCmdSetViewportWithCount &c) override;
    bool vkCmdSetScissor(const codec::Decoded_vkCmdSetScissor &c) override;
    bool vkCmdSetScissorWithCount(const codec::Decoded_vkCmdSetScissorWithCount &c) override;
    bool vkCmdBeginRenderPass(const codec::Decoded_vkCmdBeginRenderPass &c) override;
    bool vkCmdBeginRenderPass2(const codec::Decoded_vkCmdBeginRenderPass2 &c) override;
    bool vkCmdBeginRendering(const codec::Decoded_vkCmdBeginRendering &c) override;
    bool vkCmdEndRenderPass(const codec::Decoded_vkCmdEndRenderPass &c) override;
    bool vkCmdEndRenderPass2(const codec::Decoded_vkCmdEndRenderPass2 &c) override;
    bool vkCmdEndRendering(const codec::Decoded_vkCmdEndRendering &c) override;
    // The swapped split (periphery_scaling.h): clear rects of a scaled pass.
    bool vkCmdClearAttachments(const codec::Decoded_vkCmdClearAttachments &c) override;

private:
    // Waits for the GPU when work is in flight: the client destroys, frees, re-records and
    // rewrites memory after waiting on its own fences, which the agent does not replay. MemoryData
    // for buffers does not wait: it is queued (queued_writes.h).
    void quiesce();
    // Submits the MemoryData copies staged since the last submit (before anything else uses the queue).
    bool flush_writes();
    // Per command buffer instead of the whole queue: re-recording one waits for its own last submit
    // only (each submit has a fence); a command buffer never submitted as a primary (a secondary
    // may be inside a pending primary) still waits for the queue.
    void wait_for_command_buffer(std::span<const uint8_t> payload, size_t offset);
    // vkResetCommandPool: waits for the pool's last submit (the queue when it has secondaries).
    void wait_for_command_pool(std::span<const uint8_t> payload, size_t offset);
    void note_submitted(VkCommandBuffer command_buffer); // under submit_serial_
    VkFence submit_fence();              // a fence for the next submit, reclaiming those signalled
    void reclaim_fences(uint64_t up_to); // waits (bounded) for the submits up to serial `up_to`
    bool needs_quiesce(codec::VkCommandId id) const;
    void note_frame_submit();
    bool peek_create_device(std::span<const uint8_t> payload, size_t offset, std::string *error);
    // After a pipeline's creation: its stages' address fields joined into its layout's, and why it
    // is untranslatable, if it is.
    void note_pipeline_addresses(VkPipeline pipeline, VkPipelineLayout layout, uint32_t stage_count,
                                 const VkPipelineShaderStageCreateInfo *stages);

    // Secondaries in scissored passes (fovea_shading.h, FoveaShading::begin_variant): the stream of
    // each secondary that continues a render pass is kept, and recorded again into a variant of
    // our own for each differently scissored pass that executes it. A variant lives as long as the
    // secondary's recording: re-beginning or freeing the secondary frees its variants, which no
    // pending primary can use by then (a secondary is re-begun or freed only with the queue idle:
    // wait_for_command_buffer, needs_quiesce).
    struct SecondaryStream {
        std::vector<uint8_t> stream; // its vkBeginCommandBuffer through its vkEndCommandBuffer
        std::vector<std::pair<FoveaShading::PassScissor, VkCommandBuffer>> variants;
    };
    // `stream` ended the recording of command buffer `id`: kept if it continues a render pass.
    void keep_secondary_stream(uint64_t id, std::span<const uint8_t> stream);
    // The variant of secondary `id` for a pass scissored as `scissor`, recorded on first use; null
    // where the secondary is executed as recorded (shaded whole).
    VkCommandBuffer secondary_variant(uint64_t id, VkCommandBuffer secondary,
                                      const FoveaShading::PassScissor &scissor);
    void forget_secondary(uint64_t id);
    // Right after the vkBeginCommandBuffer of `command_buffer` (client id `id`) ending at `offset`:
    // the swapchain images its recording's transfers read, for FoveaShading::note_transfer_reads.
    // A light decode of the recording that follows in the payload (a command buffer's stream is
    // sent whole, after the objects it names), up to its vkEndCommandBuffer; nothing is replayed.
    void prescan_transfer_reads(std::span<const uint8_t> payload, size_t offset, uint64_t id,
                                VkCommandBuffer command_buffer);

    uint64_t session_id_;
    VulkanContext context_;
    codec::HandleTable table_;
    codec::Arena arena_;
    MemoryRebind memory_;
    SwapchainImages swapchains_{context_, table_};
    LimitGuard guard_;
    FoveaShading fovea_{vk, swapchains_};
    PeripheryScaling scaling_{vk, swapchains_}; // the swapped split's periphery, drawn scaled
    TileStreamer::Send tile_sender_;
    std::unique_ptr<TileStreamer> tiles_; // declared after context_: its worker stops before the device goes
    std::chrono::steady_clock::time_point frame_first_submit_{};
    std::string error_;
    bool gpu_busy_ = false;
    bool unsupported_format_logged_ = false;
    bool swapped_ = false;               // PeripheryConfig: the agent renders the periphery
    protocol::FoveaAgents fovea_agents_; // SplitConfig: the foveae this agent sends (an agent per eye)
    double periphery_scale_ = 1;         // its scale
    bool runtime_periphery_logged_ = false;
    bool linear_copy_logged_ = false;
    uint64_t commands_ = 0;
    uint64_t submits_ = 0;
    uint64_t memory_queued_ = 0;
    uint64_t memory_waited_ = 0;
    // Submits in flight with their fences, in submission order, and fences free for reuse.
    std::deque<std::pair<uint64_t, VkFence>> in_flight_;
    std::vector<VkFence> free_fences_;
    uint64_t submit_serial_ = 0;
    std::unordered_map<VkCommandBuffer, uint64_t> last_submit_; // by primary command buffer
    std::unordered_map<VkCommandBuffer, VkCommandPool> pool_of_;
    std::unordered_map<VkCommandPool, uint64_t> pool_last_submit_;
    std::unordered_set<VkCommandPool> pools_with_secondaries_;
    std::unordered_map<uint64_t, SecondaryStream> secondaries_; // by client id
    VkCommandPool variant_pool_ = VK_NULL_HANDLE;
    codec::Arena variant_arena_; // a variant is recorded while the primary's commands use arena_
    bool recording_variant_ = false;
    codec::Arena prescan_arena_; // prescan_transfer_reads' decoding, while the payload's uses arena_
    bool variant_failed_logged_ = false;
    uint64_t kept_stream_bytes_ = 0; // of secondaries_' streams
    BufferAddressMap addresses_;     // by the agent's buffer handle values
    std::unordered_map<VkShaderModule, ShaderAddresses> shader_addresses_; // modules that use addresses
    std::unordered_map<VkPipelineLayout, std::vector<uint32_t>> layout_address_fields_;
    std::unordered_map<VkPipeline, std::string> untranslatable_pipelines_; // -> why
    QueuedWrites writes_{context_}; // last: destroyed first, with the device still there
};

} // namespace splitvk::agent
