#include "swapchain_images.h"

#include "tile_format.h"
#include "vk_format_info.h"

#include <cstring>

namespace splitvk::agent {

namespace {

std::string shape_text(VkFormat format, VkExtent2D extent, uint32_t layers) {
    return std::string(format_name(format)) + " " + std::to_string(extent.width) + "x" +
           std::to_string(extent.height) + " in " + std::to_string(layers) + " layer(s)";
}

} // namespace

SwapchainImages::~SwapchainImages() {
    if (!context_.device) return;
    vkDeviceWaitIdle(context_.device);
    for (auto &[id, swapchain] : swapchains_)
        release(swapchain);
    context_.destroy(staging_);
    if (fence_) vkDestroyFence(context_.device, fence_, nullptr);
    if (pool_) vkDestroyCommandPool(context_.device, pool_, nullptr);
}

void SwapchainImages::release(Swapchain &swapchain) {
    if (swapchain.info.source == protocol::SwapchainImages::Source::Runtime) {
        // Adopted: the client's vkDestroyImage ends them, as it created them.
        swapchain.images.clear();
        return;
    }
    for (VkImage image : swapchain.images)
        vkDestroyImage(context_.device, image, nullptr);
    for (VkDeviceMemory memory : swapchain.memory)
        vkFreeMemory(context_.device, memory, nullptr);
    for (uint64_t id : swapchain.info.image_ids)
        table_.remove(id);
    swapchain.images.clear();
    swapchain.memory.clear();
}

void SwapchainImages::image_created(VkImage image, const VkImageCreateInfo &info) {
    if (info.imageType != VK_IMAGE_TYPE_2D || info.samples != VK_SAMPLE_COUNT_1_BIT) return;
    created_[image] = {info.format, {info.extent.width, info.extent.height}, info.arrayLayers};
}

void SwapchainImages::image_destroyed(VkImage image) {
    created_.erase(image);
}

bool SwapchainImages::adopt(const protocol::SwapchainImages &message, Swapchain &swapchain,
                            std::string *error, std::string *warning) const {
    const Shape declared{
        static_cast<VkFormat>(message.format), {message.width, message.height}, message.array_layers};
    swapchain.shape = declared;
    for (size_t i = 0; i < message.image_ids.size(); ++i) {
        const uint64_t id = message.image_ids[i];
        const codec::HandleTable::Entry *entry = table_.find(id);
        if (!entry || entry->type != VK_OBJECT_TYPE_IMAGE) {
            *error = "runtime swapchain image " + std::to_string(id) + " is not a live image";
            return false;
        }
        const VkImage image = codec::to_handle<VkImage>(entry->handle);
        const auto created = created_.find(image);
        if (created == created_.end()) {
            *error = "runtime swapchain image " + std::to_string(id) + " is not a 2D single-sample image";
            return false;
        }
        if (i == 0) {
            swapchain.shape = created->second;
        } else if (created->second != swapchain.shape) {
            *error = "runtime swapchain image " + std::to_string(id) + " is " +
                     shape_text(created->second.format, created->second.extent, created->second.layers) +
                     ", the swapchain's first image " +
                     shape_text(swapchain.shape.format, swapchain.shape.extent, swapchain.shape.layers);
            return false;
        }
        swapchain.images.push_back(image);
    }
    if (swapchain.shape != declared)
        *warning = "its images are " +
                   shape_text(swapchain.shape.format, swapchain.shape.extent, swapchain.shape.layers) +
                   ", the client declared " + shape_text(declared.format, declared.extent, declared.layers) +
                   "; they are read back as they are";
    return true;
}

bool SwapchainImages::check_format(const protocol::SwapchainImages &message, std::string *error) const {
    // The agent makes these images itself: a value vk.xml does not list, or a format no surface
    // presents, would reach the driver's vkCreateImage as undefined behaviour.
    const VkFormat format = static_cast<VkFormat>(message.format);
    const FormatInfo info = format_info(format);
    if (info.block_bytes != 0 && !info.depth && !info.stencil && !info.compressed && !info.ycbcr) return true;
    *error = std::string(format_name(format)) + " (VkFormat " + std::to_string(message.format) +
             ") is not a colour format a window presents";
    return false;
}

bool SwapchainImages::create(const protocol::SwapchainImages &message, std::string *error,
                             std::string *warning) {
    if (!context_.device) {
        *error = "SwapchainImages before vkCreateDevice";
        return false;
    }
    if (swapchains_.count(message.swapchain_id)) {
        *error = "swapchain id already has images";
        return false;
    }
    if (message.width == 0 || message.height == 0 || message.array_layers == 0) {
        *error = "empty swapchain extent";
        return false;
    }
    Swapchain swapchain;
    swapchain.info = message;
    if (message.source == protocol::SwapchainImages::Source::Runtime) {
        // An OpenXR runtime's images: the client created them with vkCreateImage, which this session
        // replayed, so they are adopted rather than made.
        if (!adopt(message, swapchain, error, warning)) return false;
        swapchains_.emplace(message.swapchain_id, std::move(swapchain));
        newest_ = {message.width, message.height};
        return true;
    }
    if (!check_format(message, error)) return false;
    swapchain.shape = {
        static_cast<VkFormat>(message.format), {message.width, message.height}, message.array_layers};
    swapchain.info.image_ids.clear();
    VkImageCreateInfo info{};
    info.sType = VK_STRUCTURE_TYPE_IMAGE_CREATE_INFO;
    info.imageType = VK_IMAGE_TYPE_2D;
    info.format = static_cast<VkFormat>(message.format);
    info.extent = {message.width, message.height, 1};
    info.mipLevels = 1;
    info.arrayLayers = message.array_layers;
    info.samples = VK_SAMPLE_COUNT_1_BIT;
    info.tiling = VK_IMAGE_TILING_OPTIMAL;
    info.usage = message.usage | VK_IMAGE_USAGE_TRANSFER_SRC_BIT;
    info.sharingMode = VK_SHARING_MODE_EXCLUSIVE;
    info.initialLayout = VK_IMAGE_LAYOUT_UNDEFINED;
    for (uint64_t id : message.image_ids) {
        VkImage image = VK_NULL_HANDLE;
        VkResult r = vkCreateImage(context_.device, &info, nullptr, &image);
        if (r != VK_SUCCESS) {
            *error = std::string("vkCreateImage for a swapchain image failed: ") + vk_result_name(r);
            release(swapchain);
            return false;
        }
        swapchain.images.push_back(image);
        VkMemoryRequirements req{};
        vkGetImageMemoryRequirements(context_.device, image, &req);
        VkMemoryAllocateInfo alloc{};
        alloc.sType = VK_STRUCTURE_TYPE_MEMORY_ALLOCATE_INFO;
        alloc.allocationSize = req.size;
        const int32_t type =
            context_.find_memory_type(req.memoryTypeBits, 0, VK_MEMORY_PROPERTY_DEVICE_LOCAL_BIT);
        alloc.memoryTypeIndex = static_cast<uint32_t>(type < 0 ? 0 : type);
        VkDeviceMemory memory = VK_NULL_HANDLE;
        r = vkAllocateMemory(context_.device, &alloc, nullptr, &memory);
        if (r == VK_SUCCESS) {
            swapchain.memory.push_back(memory);
            r = vkBindImageMemory(context_.device, image, memory, 0);
        }
        if (r != VK_SUCCESS) {
            *error = std::string("memory for a swapchain image: ") + vk_result_name(r);
            release(swapchain);
            return false;
        }
        if (!table_.insert(id, VK_OBJECT_TYPE_IMAGE, image, 0, error)) {
            release(swapchain);
            return false;
        }
        swapchain.info.image_ids.push_back(id);
    }
    swapchains_.emplace(message.swapchain_id, std::move(swapchain));
    newest_ = {message.width, message.height};
    return true;
}

const SwapchainImages::Swapchain *
SwapchainImages::presented_swapchain(uint64_t swapchain_id, uint32_t image_index, std::string *error) const {
    const auto it = swapchains_.find(swapchain_id);
    if (it == swapchains_.end()) {
        *error = "present of unknown swapchain id";
        return nullptr;
    }
    const Swapchain &swapchain = it->second;
    if (image_index >= swapchain.images.size()) {
        *error = "present of image index " + std::to_string(image_index) + " of a swapchain with " +
                 std::to_string(swapchain.images.size()) + " images";
        return nullptr;
    }
    return &swapchain;
}

bool SwapchainImages::presented(uint64_t swapchain_id, uint32_t image_index, Presented *out,
                                std::string *error) const {
    const Swapchain *swapchain = presented_swapchain(swapchain_id, image_index, error);
    if (!swapchain) return false;
    *out = {swapchain->images[image_index], swapchain->info.image_ids[image_index],
            swapchain->shape.format,        static_cast<VkImageLayout>(swapchain->info.presented_layout),
            swapchain->shape.extent,        swapchain->shape.layers};
    return true;
}

bool SwapchainImages::runtime_image(uint64_t image_id, const std::vector<split::RuntimeEye> **eyes,
                                    uint32_t *layers) const {
    for (const auto &[id, swapchain] : swapchains_)
        if (swapchain.info.source == protocol::SwapchainImages::Source::Runtime)
            for (uint64_t image : swapchain.info.image_ids)
                if (image == image_id) {
                    if (eyes) *eyes = &swapchain.eyes;
                    if (layers) *layers = swapchain.info.array_layers;
                    return true;
                }
    return false;
}

std::vector<SwapchainImages::RuntimeSwapchain> SwapchainImages::runtime_swapchains(VkExtent2D extent,
                                                                                   bool *window) const {
    std::vector<RuntimeSwapchain> out;
    if (window) *window = false;
    for (const auto &[id, swapchain] : swapchains_) {
        if (swapchain.info.width != extent.width || swapchain.info.height != extent.height) continue;
        if (swapchain.info.source == protocol::SwapchainImages::Source::Runtime)
            out.push_back({swapchain.info.array_layers, &swapchain.eyes});
        else if (window)
            *window = true;
    }
    return out;
}

bool SwapchainImages::note_eye(uint64_t swapchain_id, const split::RuntimeEye &eye, std::string *error) {
    const auto it = swapchains_.find(swapchain_id);
    if (it == swapchains_.end() || it->second.info.source != protocol::SwapchainImages::Source::Runtime) {
        *error = "not an OpenXR runtime's swapchain";
        return false;
    }
    const protocol::SwapchainImages &info = it->second.info;
    const VkRect2D &r = eye.rect;
    if (eye.layer >= info.array_layers || r.offset.x < 0 || r.offset.y < 0 ||
        uint64_t(r.offset.x) + r.extent.width > info.width ||
        uint64_t(r.offset.y) + r.extent.height > info.height) {
        *error = "eye in layer " + std::to_string(eye.layer) + " at " + std::to_string(r.offset.x) + "," +
                 std::to_string(r.offset.y) + " " + std::to_string(r.extent.width) + "x" +
                 std::to_string(r.extent.height) + " outside its " + std::to_string(info.width) + "x" +
                 std::to_string(info.height) + " images of " + std::to_string(info.array_layers) +
                 " layer(s)";
        return false;
    }
    split::note_runtime_eye(it->second.eyes, eye);
    return true;
}

bool SwapchainImages::destroy(uint64_t swapchain_id, std::string *error) {
    auto it = swapchains_.find(swapchain_id);
    if (it == swapchains_.end()) {
        *error = "unknown swapchain id";
        return false;
    }
    vkDeviceWaitIdle(context_.device);
    release(it->second);
    swapchains_.erase(it);
    return true;
}

bool SwapchainImages::ensure_readback(VkDeviceSize bytes, std::string *error) {
    VkResult r = VK_SUCCESS;
    if (!pool_) {
        VkCommandPoolCreateInfo pool{};
        pool.sType = VK_STRUCTURE_TYPE_COMMAND_POOL_CREATE_INFO;
        pool.flags = VK_COMMAND_POOL_CREATE_RESET_COMMAND_BUFFER_BIT;
        pool.queueFamilyIndex = context_.queue_family;
        r = vkCreateCommandPool(context_.device, &pool, nullptr, &pool_);
        if (r == VK_SUCCESS) {
            VkCommandBufferAllocateInfo cb{};
            cb.sType = VK_STRUCTURE_TYPE_COMMAND_BUFFER_ALLOCATE_INFO;
            cb.commandPool = pool_;
            cb.level = VK_COMMAND_BUFFER_LEVEL_PRIMARY;
            cb.commandBufferCount = 1;
            r = vkAllocateCommandBuffers(context_.device, &cb, &command_buffer_);
        }
        if (r == VK_SUCCESS) {
            VkFenceCreateInfo fence{};
            fence.sType = VK_STRUCTURE_TYPE_FENCE_CREATE_INFO;
            r = vkCreateFence(context_.device, &fence, nullptr, &fence_);
        }
        if (r != VK_SUCCESS) {
            *error = std::string("readback setup: ") + vk_result_name(r);
            return false;
        }
    }
    if (staging_.size >= bytes) return true;
    context_.destroy(staging_);
    return context_.create_readback_buffer(bytes, &staging_, error);
}

bool SwapchainImages::read_back(uint64_t swapchain_id, uint32_t image_index, Rect rect,
                                protocol::VerifyFrame &out, bool *unsupported, std::string *error) {
    *unsupported = false;
    const Swapchain *found = presented_swapchain(swapchain_id, image_index, error);
    if (!found) return false;
    const Swapchain &swapchain = *found;
    const Shape &shape = swapchain.shape;
    const uint32_t texel_bytes = tile_texel_bytes(shape.format);
    if (texel_bytes == 0) {
        *unsupported = true;
        return true;
    }
    // The whole image is every layer of it (verification); a rectangle is one of layer 0.
    const uint32_t layers = rect.width == 0 ? shape.layers : 1;
    if (rect.width == 0) rect = {0, 0, shape.extent.width, shape.extent.height};
    if (rect.height == 0 || uint64_t{rect.x} + rect.width > shape.extent.width ||
        uint64_t{rect.y} + rect.height > shape.extent.height) {
        *error = "readback rectangle outside the image";
        return false;
    }
    const VkDeviceSize bytes = VkDeviceSize{rect.width} * rect.height * texel_bytes * layers;
    if (!ensure_readback(bytes, error)) return false;

    VkBufferImageCopy region{};
    region.imageSubresource = {VK_IMAGE_ASPECT_COLOR_BIT, 0, 0, layers};
    region.imageOffset = {static_cast<int32_t>(rect.x), static_cast<int32_t>(rect.y), 0};
    region.imageExtent = {rect.width, rect.height, 1};
    VulkanContext::record_present_readback(command_buffer_, swapchain.images[image_index],
                                           static_cast<VkImageLayout>(swapchain.info.presented_layout),
                                           staging_, {region});
    VkSubmitInfo submit{};
    submit.sType = VK_STRUCTURE_TYPE_SUBMIT_INFO;
    submit.commandBufferCount = 1;
    submit.pCommandBuffers = &command_buffer_;
    VkResult r = vkQueueSubmit(context_.queue, 1, &submit, fence_);
    if (r == VK_SUCCESS) r = vkWaitForFences(context_.device, 1, &fence_, VK_TRUE, UINT64_MAX);
    vkResetFences(context_.device, 1, &fence_);
    if (r != VK_SUCCESS) {
        *error = std::string("readback submit: ") + vk_result_name(r);
        return false;
    }
    context_.invalidate(staging_);
    out.swapchain_id = swapchain_id;
    out.image_index = image_index;
    out.width = rect.width;
    out.height = rect.height;
    out.format = static_cast<uint32_t>(shape.format);
    out.layers = layers;
    out.pixels.resize(static_cast<size_t>(bytes));
    std::memcpy(out.pixels.data(), staging_.mapped, out.pixels.size());
    return true;
}

bool SwapchainImages::find_image(VkImage image, uint64_t *image_id, VkExtent2D *extent) const {
    for (const auto &[id, swapchain] : swapchains_)
        for (size_t i = 0; i < swapchain.images.size(); ++i)
            if (swapchain.images[i] == image && i < swapchain.info.image_ids.size()) {
                *image_id = swapchain.info.image_ids[i];
                *extent = {swapchain.info.width, swapchain.info.height};
                return true;
            }
    return false;
}

} // namespace splitvk::agent
