#pragma once

// What the agent's GPU cannot do of what it replays. The client's application sizes
// and aligns by the limits it was told; where those are wider than this GPU's (an application that
// ignores what it was told, SPLITVK_ENVELOPE=client, or an --emulate-limits device), the driver
// would draw garbage without a word (a uniform buffer offset of 0x110 on a GPU that needs 0x40
// reads the wrong slot), and the layer would composite it as if it were right. The guard checks
// the commands where that happens silently and marks the frames that use them, so that their
// tiles go out flagged invalid and the client shows the periphery there instead.
//
//   descriptor writes  buffer offsets and ranges against the alignments and maxima; a violating
//                      write is replayed aligned down (well-defined on every GPU) and taints
//                      its descriptor until a valid write replaces it
//   dynamic offsets    against the alignments, at vkCmdBindDescriptorSets: taint the command buffer
//   images             extents, layers and format features against this GPU: taint the session
//
// A submit of a command buffer that is tainted, or that binds a tainted descriptor set, makes the
// current frame invalid. Each kind of violation is logged once per session.

#include "device_envelope.h"

#include <vulkan/vulkan.h>

#include <cstdint>
#include <map>
#include <set>
#include <string>
#include <unordered_map>
#include <unordered_set>
#include <utility>
#include <vector>

namespace splitvk::agent {

class LimitGuard {
public:
    LimitGuard(uint64_t session_id, protocol::DeviceDescription device);

    // Returns the writes to pass to the driver: those that break a limit, aligned down.
    // `storage` holds the rewritten buffer infos and must outlive the driver call.
    const VkWriteDescriptorSet *descriptor_writes(uint32_t count, const VkWriteDescriptorSet *writes,
                                                  std::vector<VkWriteDescriptorSet> &rewritten,
                                                  std::vector<VkDescriptorBufferInfo> &storage);
    void descriptor_copies(uint32_t count, const VkCopyDescriptorSet *copies);
    void descriptor_sets_freed(uint32_t count, const VkDescriptorSet *sets);

    void command_buffer_begun(VkCommandBuffer command_buffer);
    void sets_bound(VkCommandBuffer command_buffer, uint32_t set_count, const VkDescriptorSet *sets,
                    uint32_t dynamic_count, const uint32_t *dynamic_offsets);
    void image_created(const VkImageCreateInfo &info);
    // A buffer device address recorded into `command_buffer` that the agent cannot translate
    // (buffer_addresses.h): run, the command buffer would read or write wherever that number points
    // on this GPU (a fault, or memory of anything else). It is never submitted (must_skip()), and,
    // since later frames may read what it would have written, the session is tainted: every frame
    // from now on is flagged invalid. `detail` is logged once per session.
    void untranslatable_address(VkCommandBuffer command_buffer, const std::string &detail);
    bool must_skip(VkCommandBuffer command_buffer) const;
    // vkCmdExecuteCommands: what taints the secondaries taints the primary that executes them.
    void executed(VkCommandBuffer primary, uint32_t count, const VkCommandBuffer *secondaries);

    void submitted(uint32_t count, const VkCommandBuffer *command_buffers);
    // Whether the frame now presented used anything this GPU cannot honour; resets for the next.
    bool take_frame_invalid();
    uint64_t invalid_frames() const { return invalid_frames_; }

private:
    void violation(const std::string &kind, const std::string &detail);
    bool set_tainted(VkDescriptorSet set) const;

    uint64_t session_id_;
    protocol::DeviceDescription device_;
    // (binding, array element) of each set whose last write broke a limit.
    std::unordered_map<VkDescriptorSet, std::set<std::pair<uint32_t, uint32_t>>> tainted_descriptors_;
    struct Recorded {
        std::vector<VkDescriptorSet> sets;
        bool tainted = false;
        bool skip = false; // untranslatable_address()
    };
    std::unordered_map<VkCommandBuffer, Recorded> command_buffers_;
    bool session_tainted_ = false;
    bool frame_invalid_ = false;
    uint64_t invalid_frames_ = 0;
    std::unordered_set<std::string> logged_;
};

} // namespace splitvk::agent
