// --path secondary: the direct path's pass into the swapchain image, with its contents recorded
// in secondary command buffers by several threads (VK_SUBPASS_CONTENTS_SECONDARY_COMMAND_BUFFERS).
// Each thread has one command pool per frame slot and records one secondary per eye with its
// share of the draws. The inheritance info names the render pass but not the framebuffer, as
// engines that record ahead of knowing the swapchain image do. The primary executes them eye by
// eye, thread by thread, which is the direct path's draw order: the same picture.
#include "path_direct.h"
#include "paths.h"

#include <array>
#include <exception>
#include <thread>
#include <vector>

namespace atrium {

namespace {

constexpr uint32_t thread_count = 4;

class SecondaryPath : public DirectPath {
public:
    SecondaryPath(const SceneGpu &scene, const Swapchain &swapchain, const RendererOptions &options)
        : DirectPath(scene, swapchain, options) {
        for (auto &slot : workers_)
            for (Worker &worker : slot) {
                VkCommandPoolCreateInfo pool{};
                pool.sType = VK_STRUCTURE_TYPE_COMMAND_POOL_CREATE_INFO;
                pool.flags = VK_COMMAND_POOL_CREATE_TRANSIENT_BIT;
                pool.queueFamilyIndex = scene.context().queue_family();
                ATRIUM_VK_CHECK(vkCreateCommandPool(device_, &pool, nullptr, &worker.pool));
                VkCommandBufferAllocateInfo alloc{};
                alloc.sType = VK_STRUCTURE_TYPE_COMMAND_BUFFER_ALLOCATE_INFO;
                alloc.commandPool = worker.pool;
                alloc.level = VK_COMMAND_BUFFER_LEVEL_SECONDARY;
                alloc.commandBufferCount = options.eyes;
                ATRIUM_VK_CHECK(vkAllocateCommandBuffers(device_, &alloc, worker.eyes.data()));
            }
    }

    ~SecondaryPath() override {
        for (auto &slot : workers_)
            for (Worker &worker : slot)
                vkDestroyCommandPool(device_, worker.pool, nullptr);
    }

protected:
    VkSubpassContents contents() const override { return VK_SUBPASS_CONTENTS_SECONDARY_COMMAND_BUFFERS; }

    void record_contents(const FrameContext &frame) override {
        auto &workers = workers_[frame.slot];
        std::array<std::exception_ptr, thread_count> errors;
        std::vector<std::thread> threads;
        const size_t draws = scene_.draw_count();
        for (uint32_t t = 0; t < thread_count; ++t)
            threads.emplace_back([&, t] {
                try {
                    record_worker(workers[t], frame.slot, draws * t / thread_count,
                                  draws * (t + 1) / thread_count);
                } catch (...) {
                    errors[t] = std::current_exception();
                }
            });
        for (std::thread &thread : threads)
            thread.join();
        for (const std::exception_ptr &error : errors)
            if (error) std::rethrow_exception(error);
        for (uint32_t eye = 0; eye < options_.eyes; ++eye)
            for (const Worker &worker : workers)
                vkCmdExecuteCommands(frame.cmd, 1, &worker.eyes[eye]);
    }

private:
    struct Worker {
        VkCommandPool pool = VK_NULL_HANDLE; // used by one thread at a time
        std::array<VkCommandBuffer, 2> eyes{};
    };

    // The slot's fence was waited for before recording, so its pools are free to reset.
    void record_worker(Worker &worker, uint32_t slot, size_t first, size_t end) const {
        ATRIUM_VK_CHECK(vkResetCommandPool(device_, worker.pool, 0));
        VkCommandBufferInheritanceInfo inheritance{};
        inheritance.sType = VK_STRUCTURE_TYPE_COMMAND_BUFFER_INHERITANCE_INFO;
        inheritance.renderPass = present_pass_; // compatible with the readback pass
        inheritance.subpass = 0;
        // --dynamic-rendering: no render pass, only the formats of the rendering that executes them.
        const VkFormat color_format = swapchain_.format();
        VkCommandBufferInheritanceRenderingInfoKHR rendering{};
        rendering.sType = VK_STRUCTURE_TYPE_COMMAND_BUFFER_INHERITANCE_RENDERING_INFO_KHR;
        rendering.colorAttachmentCount = 1;
        rendering.pColorAttachmentFormats = &color_format;
        rendering.depthAttachmentFormat = depth_format;
        rendering.rasterizationSamples = VK_SAMPLE_COUNT_1_BIT;
        if (options_.dynamic_rendering) {
            inheritance.pNext = &rendering;
            inheritance.renderPass = VK_NULL_HANDLE;
        }
        VkCommandBufferBeginInfo begin{};
        begin.sType = VK_STRUCTURE_TYPE_COMMAND_BUFFER_BEGIN_INFO;
        begin.flags =
            VK_COMMAND_BUFFER_USAGE_ONE_TIME_SUBMIT_BIT | VK_COMMAND_BUFFER_USAGE_RENDER_PASS_CONTINUE_BIT;
        begin.pInheritanceInfo = &inheritance;
        for (uint32_t eye = 0; eye < options_.eyes; ++eye) {
            const VkCommandBuffer cmd = worker.eyes[eye];
            ATRIUM_VK_CHECK(vkBeginCommandBuffer(cmd, &begin));
            scene_.bind(cmd, pipeline_, slot);
            record_eye(cmd, eye, first, end);
            ATRIUM_VK_CHECK(vkEndCommandBuffer(cmd));
        }
    }

    std::array<std::array<Worker, thread_count>, frames_in_flight> workers_;
};

} // namespace

std::unique_ptr<RenderPath> make_secondary_path(const SceneGpu &scene, const Swapchain &swapchain,
                                                const RendererOptions &options) {
    return std::make_unique<SecondaryPath>(scene, swapchain, options);
}

} // namespace atrium
