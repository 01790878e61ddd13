// splitvk-agent end to end: the real agent binary listens on 127.0.0.1 (only), and this
// test is its client, speaking the protocol library and the generated codec. Every test reads the
// agent's log, which is part of the contract: one line per session end with its reason.

#include "codec.h"
#include "handshake.h"
#include "metadata.h"
#include "periphery.h"
#include "split_geometry.h"
#include "tile_codec.h"
#include "transport.h"
#include "vk_codec.h"
#include "vk_format_info.h"
#include "wire.h"

#include <algorithm>
#include <chrono>
#include <cmath>
#include <cstdio>
#include <cstdlib>
#include <cstring>
#include <filesystem>
#include <fstream>
#include <optional>
#include <sstream>
#include <string>
#include <thread>
#include <vector>

#include <arpa/inet.h>
#include <gtest/gtest.h>
#include <netinet/in.h>
#include <pwd.h>
#include <signal.h>
#include <sys/socket.h>
#include <sys/wait.h>
#include <unistd.h>

namespace {

using namespace std::chrono_literals;
using namespace splitvk;
using protocol::MessageType;

template <class H>
H id(uint64_t v) {
    return codec::to_handle<H>(v);
}

// Client ids of the good stream.
constexpr uint64_t kPhysicalDevice = 0x1000, kDevice = 0x2000, kQueue = 0x3000, kBuffer = 0x4000,
                   kMemory = 0x5000, kPool = 0x6000, kCommandBuffer = 0x7000, kSwapchain = 0x8000,
                   kImage = 0x9000;
constexpr uint32_t kWidth = 4, kHeight = 8; // the swapchain image: 32 pixels, 128 bytes

uint16_t free_loopback_port() {
    const int fd = socket(AF_INET, SOCK_STREAM, 0);
    sockaddr_in addr{};
    addr.sin_family = AF_INET;
    addr.sin_addr.s_addr = htonl(INADDR_LOOPBACK);
    addr.sin_port = 0;
    if (bind(fd, reinterpret_cast<sockaddr *>(&addr), sizeof(addr)) != 0) return 0;
    socklen_t len = sizeof(addr);
    getsockname(fd, reinterpret_cast<sockaddr *>(&addr), &len);
    close(fd);
    return ntohs(addr.sin_port);
}

std::string read_file(const std::string &path) {
    std::ifstream in(path);
    std::stringstream s;
    s << in.rdbuf();
    return s.str();
}

// The agent binary, started with the given options on a free loopback port.
class Agent {
public:
    explicit Agent(std::vector<std::string> extra = {}) {
        port_ = free_loopback_port();
        char dir[] = "/tmp/splitvk-agent-test-XXXXXX";
        dir_ = mkdtemp(dir);
        log_ = dir_ + "/agent.log";
        std::vector<std::string> args = {SPLITVK_AGENT_BINARY, "--listen",
                                         "127.0.0.1:" + std::to_string(port_)};
        for (auto &e : extra) {
            if (e == "TOKEN_FILE") {
                e = dir_ + "/token";
                std::ofstream(e) << "right-token\n";
            }
            args.push_back(e);
        }
        // The agent's environment is the test's, with LeakSanitizer off in the sanitizer build: at the
        // listener's exit it reports the Vulkan driver's allocations from enumerating the GPU, made
        // by a module the loader has unloaded by then, which no suppression can name (and with
        // abort_on_error the listener then dies of SIGABRT). ASan's other checks stay on; a later
        // flag wins. Prepared before fork: only exec follows it.
        std::vector<std::string> env;
        bool asan_set = false;
        for (char **e = environ; *e; ++e) {
            env.emplace_back(*e);
            if (env.back().rfind("ASAN_OPTIONS=", 0) == 0) {
                env.back() += ":detect_leaks=0";
                asan_set = true;
            }
        }
        if (!asan_set) env.emplace_back("ASAN_OPTIONS=detect_leaks=0");
        std::vector<char *> envp;
        for (auto &e : env)
            envp.push_back(e.data());
        envp.push_back(nullptr);
        std::vector<char *> argv;
        for (auto &a : args)
            argv.push_back(a.data());
        argv.push_back(nullptr);
        pid_ = fork();
        if (pid_ == 0) {
            std::FILE *f = std::freopen(log_.c_str(), "w", stderr);
            (void)f;
            execve(argv[0], argv.data(), envp.data());
            _exit(127);
        }
        started_ = wait_for_log("listening on", 1, 20s);
    }
    ~Agent() {
        stop();
        std::remove((dir_ + "/token").c_str());
        std::remove(log_.c_str());
        rmdir(dir_.c_str());
    }

    // SIGTERM; returns the wait status.
    int stop() {
        int status = -1;
        if (pid_ > 0) {
            kill(pid_, SIGTERM);
            waitpid(pid_, &status, 0);
            pid_ = -1;
        }
        return status;
    }
    bool started() const { return started_; }
    uint16_t port() const { return port_; }
    pid_t pid() const { return pid_; }
    std::string log() const { return read_file(log_); }

    // Waits until `text` occurs at least `count` times in the log.
    bool wait_for_log(const std::string &text, size_t count = 1,
                      std::chrono::milliseconds timeout = 60s) const {
        const auto deadline = std::chrono::steady_clock::now() + timeout;
        while (std::chrono::steady_clock::now() < deadline) {
            if (occurrences(text) >= count) return true;
            std::this_thread::sleep_for(20ms);
        }
        return false;
    }
    size_t occurrences(const std::string &text) const {
        const std::string l = log();
        size_t n = 0;
        for (size_t at = l.find(text); at != std::string::npos; at = l.find(text, at + 1))
            ++n;
        return n;
    }
    // The line for session `n`'s end.
    bool wait_for_end(uint64_t n, const std::string &reason) const {
        return wait_for_log("session " + std::to_string(n) + " (pid", 2) &&
               wait_for_log("ended: " + reason, 1) && log_has_end(n, reason);
    }
    bool log_has_end(uint64_t n, const std::string &reason) const {
        const std::string l = log();
        const std::string prefix = "session " + std::to_string(n) + " (pid ";
        for (size_t at = l.find(prefix); at != std::string::npos; at = l.find(prefix, at + 1)) {
            const size_t eol = l.find('\n', at);
            const std::string line = l.substr(at, eol - at);
            if (line.find("ended: " + reason) != std::string::npos) return true;
        }
        return false;
    }

    long rss_kib() const {
        std::ifstream in("/proc/" + std::to_string(pid_) + "/status");
        std::string line;
        while (std::getline(in, line))
            if (line.rfind("VmRSS:", 0) == 0) return std::atol(line.c_str() + 6);
        return -1;
    }

private:
    pid_t pid_ = -1;
    uint16_t port_ = 0;
    std::string dir_;
    std::string log_;
    bool started_ = false;
};

// A client session through the protocol library.
struct Client {
    std::unique_ptr<protocol::Connection> connection;
    std::string error;
    uint64_t granted = 0; // the Welcome's capabilities

    bool connect(const Agent &agent, const std::string &token = {}) {
        auto c = protocol::Connection::connect("127.0.0.1", agent.port(), 5s);
        if (!c) {
            error = c.error();
            return false;
        }
        connection = std::move(c.value());
        connection->start([](const std::string &) {});
        protocol::Hello hello;
        hello.client_name = "agent_session_test";
        hello.client_gpu_name = "fake";
        hello.codec_fingerprint = protocol::session_fingerprint(codec::kCodecFingerprint);
        hello.token.assign(token.begin(), token.end());
        auto welcome = protocol::client_handshake(*connection, hello, 10s);
        if (!welcome) {
            error = welcome.error();
            return false;
        }
        granted = welcome->capabilities;
        return true;
    }
    bool send(MessageType type, std::vector<uint8_t> payload) {
        return connection->send_owned(type, std::move(payload), 5000ms) == protocol::SendResult::Queued;
    }
    bool commands(codec::Encoder &e) { return send(MessageType::Commands, e.take()); }
    void bye() {
        send(MessageType::Goodbye, protocol::encode_goodbye({"test done"}));
        connection->flush(2000ms);
        connection->close();
    }
};

// vkCreateDevice (the first command), vkGetDeviceQueue, a buffer with memory bound.
void encode_setup(codec::Encoder &e) {
    const float priority = 1.0f;
    VkDeviceQueueCreateInfo queue{};
    queue.sType = VK_STRUCTURE_TYPE_DEVICE_QUEUE_CREATE_INFO;
    queue.queueCount = 1;
    queue.pQueuePriorities = &priority;
    VkDeviceCreateInfo device{};
    device.sType = VK_STRUCTURE_TYPE_DEVICE_CREATE_INFO;
    device.queueCreateInfoCount = 1;
    device.pQueueCreateInfos = &queue;
    VkDevice dev = id<VkDevice>(kDevice);
    codec::encode_vkCreateDevice(e, id<VkPhysicalDevice>(kPhysicalDevice), &device, nullptr, &dev);
    VkQueue q = id<VkQueue>(kQueue);
    codec::encode_vkGetDeviceQueue(e, dev, 0, 0, &q);
    VkBufferCreateInfo buffer{};
    buffer.sType = VK_STRUCTURE_TYPE_BUFFER_CREATE_INFO;
    buffer.size = 128;
    buffer.usage = VK_BUFFER_USAGE_TRANSFER_SRC_BIT | VK_BUFFER_USAGE_TRANSFER_DST_BIT;
    VkBuffer b = id<VkBuffer>(kBuffer);
    codec::encode_vkCreateBuffer(e, dev, &buffer, nullptr, &b);
    VkMemoryAllocateInfo alloc{};
    alloc.sType = VK_STRUCTURE_TYPE_MEMORY_ALLOCATE_INFO;
    alloc.allocationSize = 4096; // the client's size and type index mean nothing to the agent
    alloc.memoryTypeIndex = 7;
    VkDeviceMemory m = id<VkDeviceMemory>(kMemory);
    codec::encode_vkAllocateMemory(e, dev, &alloc, nullptr, &m);
}

std::vector<uint8_t> pattern(size_t n, uint8_t seed) {
    std::vector<uint8_t> v(n);
    for (size_t i = 0; i < n; ++i)
        v[i] = static_cast<uint8_t>(seed + i * 7);
    return v;
}

protocol::MemoryData memory_data(uint64_t offset, std::vector<uint8_t> bytes) {
    protocol::MemoryData m;
    m.device_id = kDevice;
    m.memory_id = kMemory;
    m.offset = offset;
    m.bytes = std::move(bytes);
    return m;
}

// The good stream: memory data before and after the bind (at client offset 256), a command
// buffer that fills half the buffer and copies the whole buffer into a swapchain image, a
// submit, and a verified present. Returns the pixels the agent sent back.
bool run_good_stream(Client &client, std::vector<uint8_t> *pixels, std::string *why) {
    codec::Encoder e;
    encode_setup(e);
    if (!client.commands(e)) return *why = "send setup", false;
    // Before the bind: lands in the shadow; after: routed to the buffer directly.
    if (!client.send(MessageType::MemoryData, protocol::encode(memory_data(256, pattern(32, 1)))))
        return *why = "send", false;
    VkDevice dev = id<VkDevice>(kDevice);
    codec::encode_vkBindBufferMemory(e, dev, id<VkBuffer>(kBuffer), id<VkDeviceMemory>(kMemory), 256);
    if (!client.commands(e)) return *why = "send bind", false;
    if (!client.send(MessageType::MemoryData, protocol::encode(memory_data(256 + 32, pattern(32, 101)))))
        return *why = "send", false;

    protocol::SwapchainImages sc;
    sc.device_id = kDevice;
    sc.swapchain_id = kSwapchain;
    sc.width = kWidth;
    sc.height = kHeight;
    sc.format = VK_FORMAT_R8G8B8A8_UNORM;
    sc.usage = VK_IMAGE_USAGE_COLOR_ATTACHMENT_BIT | VK_IMAGE_USAGE_TRANSFER_DST_BIT;
    sc.image_ids = {kImage};
    if (!client.send(MessageType::SwapchainImages, protocol::encode(sc))) return *why = "send", false;

    VkCommandPoolCreateInfo pool{};
    pool.sType = VK_STRUCTURE_TYPE_COMMAND_POOL_CREATE_INFO;
    VkCommandPool p = id<VkCommandPool>(kPool);
    codec::encode_vkCreateCommandPool(e, dev, &pool, nullptr, &p);
    VkCommandBufferAllocateInfo cba{};
    cba.sType = VK_STRUCTURE_TYPE_COMMAND_BUFFER_ALLOCATE_INFO;
    cba.commandPool = p;
    cba.level = VK_COMMAND_BUFFER_LEVEL_PRIMARY;
    cba.commandBufferCount = 1;
    VkCommandBuffer cb = id<VkCommandBuffer>(kCommandBuffer);
    codec::encode_vkAllocateCommandBuffers(e, dev, &cba, &cb);
    VkCommandBufferBeginInfo begin{};
    begin.sType = VK_STRUCTURE_TYPE_COMMAND_BUFFER_BEGIN_INFO;
    codec::encode_vkBeginCommandBuffer(e, cb, &begin, VK_COMMAND_BUFFER_LEVEL_PRIMARY);
    codec::encode_vkCmdFillBuffer(e, cb, id<VkBuffer>(kBuffer), 64, 64, 0xdeadbeefu);
    VkBufferMemoryBarrier bb{};
    bb.sType = VK_STRUCTURE_TYPE_BUFFER_MEMORY_BARRIER;
    bb.srcAccessMask = VK_ACCESS_TRANSFER_WRITE_BIT;
    bb.dstAccessMask = VK_ACCESS_TRANSFER_READ_BIT;
    bb.srcQueueFamilyIndex = bb.dstQueueFamilyIndex = VK_QUEUE_FAMILY_IGNORED;
    bb.buffer = id<VkBuffer>(kBuffer);
    bb.size = VK_WHOLE_SIZE;
    VkImageMemoryBarrier ib{};
    ib.sType = VK_STRUCTURE_TYPE_IMAGE_MEMORY_BARRIER;
    ib.dstAccessMask = VK_ACCESS_TRANSFER_WRITE_BIT;
    ib.oldLayout = VK_IMAGE_LAYOUT_UNDEFINED;
    ib.newLayout = VK_IMAGE_LAYOUT_TRANSFER_DST_OPTIMAL;
    ib.srcQueueFamilyIndex = ib.dstQueueFamilyIndex = VK_QUEUE_FAMILY_IGNORED;
    ib.image = id<VkImage>(kImage);
    ib.subresourceRange = {VK_IMAGE_ASPECT_COLOR_BIT, 0, 1, 0, 1};
    codec::encode_vkCmdPipelineBarrier(e, cb, VK_PIPELINE_STAGE_TRANSFER_BIT, VK_PIPELINE_STAGE_TRANSFER_BIT,
                                       0, 0, nullptr, 1, &bb, 1, &ib);
    VkBufferImageCopy region{};
    region.imageSubresource = {VK_IMAGE_ASPECT_COLOR_BIT, 0, 0, 1};
    region.imageExtent = {kWidth, kHeight, 1};
    codec::encode_vkCmdCopyBufferToImage(e, cb, id<VkBuffer>(kBuffer), id<VkImage>(kImage),
                                         VK_IMAGE_LAYOUT_TRANSFER_DST_OPTIMAL, 1, &region);
    ib.srcAccessMask = VK_ACCESS_TRANSFER_WRITE_BIT;
    ib.dstAccessMask = 0;
    ib.oldLayout = VK_IMAGE_LAYOUT_TRANSFER_DST_OPTIMAL;
    ib.newLayout = VK_IMAGE_LAYOUT_PRESENT_SRC_KHR;
    codec::encode_vkCmdPipelineBarrier(e, cb, VK_PIPELINE_STAGE_TRANSFER_BIT,
                                       VK_PIPELINE_STAGE_BOTTOM_OF_PIPE_BIT, 0, 0, nullptr, 0, nullptr, 1,
                                       &ib);
    codec::encode_vkEndCommandBuffer(e, cb);
    VkSubmitInfo submit{};
    submit.sType = VK_STRUCTURE_TYPE_SUBMIT_INFO;
    submit.commandBufferCount = 1;
    submit.pCommandBuffers = &cb;
    codec::encode_vkQueueSubmit(e, id<VkQueue>(kQueue), 1, &submit, VK_NULL_HANDLE);
    if (!client.commands(e)) return *why = "send commands", false;

    protocol::FramePresent present;
    present.frame = 0;
    present.queue_id = kQueue;
    present.flags = protocol::kPresentVerify;
    present.images = {{kSwapchain, 0}};
    if (!client.send(MessageType::FramePresent, protocol::encode(present)))
        return *why = "send present", false;

    auto reply = client.connection->receive(60s);
    if (!reply) return *why = "no VerifyFrame: " + client.connection->close_reason(), false;
    if (reply->type != protocol::to_wire(MessageType::VerifyFrame))
        return *why = std::string("got ") + protocol::message_type_name(reply->type), false;
    auto frame = protocol::decode_verify_frame(reply->payload, 1u << 20);
    if (!frame) return *why = frame.error(), false;
    if (frame->width != kWidth || frame->height != kHeight || frame->swapchain_id != kSwapchain)
        return *why = "VerifyFrame header", false;
    *pixels = frame->pixels;

    // Tear down what the stream created, the way an application does.
    codec::encode_vkFreeCommandBuffers(e, dev, p, 1, &cb);
    codec::encode_vkDestroyCommandPool(e, dev, p, nullptr);
    codec::encode_vkDestroyBuffer(e, dev, id<VkBuffer>(kBuffer), nullptr);
    codec::encode_vkFreeMemory(e, dev, id<VkDeviceMemory>(kMemory), nullptr);
    if (!client.commands(e)) return *why = "send teardown", false;
    protocol::SwapchainDestroyed destroyed{kDevice, kSwapchain};
    if (!client.send(MessageType::SwapchainDestroyed, protocol::encode(destroyed)))
        return *why = "send", false;
    return true;
}

std::vector<uint8_t> expected_pixels() {
    std::vector<uint8_t> v = pattern(32, 1);
    const auto b = pattern(32, 101);
    v.insert(v.end(), b.begin(), b.end());
    for (int i = 0; i < 16; ++i) {
        const uint32_t word = 0xdeadbeefu;
        for (int k = 0; k < 4; ++k)
            v.push_back(static_cast<uint8_t>(word >> (8 * k)));
    }
    return v;
}

// A session that runs the good stream and ends cleanly.
void expect_good_session(Agent &agent, uint64_t session) {
    Client client;
    ASSERT_TRUE(client.connect(agent)) << client.error;
    std::vector<uint8_t> pixels;
    std::string why;
    ASSERT_TRUE(run_good_stream(client, &pixels, &why)) << why << "\n" << agent.log();
    EXPECT_EQ(pixels, expected_pixels());
    client.bye();
    EXPECT_TRUE(agent.wait_for_end(session, "closed by the client")) << agent.log();
}

// --- linear images: the client's layout is not the agent's ------------------------------------

// A 4x8 RGBA8 linear image with 2 layers, laid out as a driver with 80-byte rows and layers 1024
// bytes apart would (lavapipe packs the 16-byte rows), bound at client offset 512.
constexpr uint64_t kLinearImage = 0xa000, kLinearMemory = 0xb000;
constexpr VkDeviceSize kLinearBind = 512, kClientRowPitch = 80, kClientArrayPitch = 1024;
constexpr uint32_t kLinearLayers = 2;

uint8_t texel_byte(uint32_t layer, uint32_t x, uint32_t y, uint32_t k) {
    return static_cast<uint8_t>(layer * 97 + y * 31 + x * 7 + k * 3 + 1);
}

protocol::ImageLayouts client_layouts() {
    protocol::ImageLayouts m;
    m.device_id = kDevice;
    m.image_id = kLinearImage;
    m.format = VK_FORMAT_R8G8B8A8_UNORM;
    m.width = kWidth;
    m.height = kHeight;
    m.mip_levels = 1;
    m.array_layers = kLinearLayers;
    for (uint32_t layer = 0; layer < kLinearLayers; ++layer)
        m.subresources.push_back({VK_IMAGE_ASPECT_COLOR_BIT, 0, layer, layer * kClientArrayPitch,
                                  kClientRowPitch * kHeight, kClientRowPitch, kClientArrayPitch, 0});
    return m;
}

// The client's allocation as its host wrote it: texels in its layout, 0xee in the row padding.
std::vector<uint8_t> client_linear_memory() {
    std::vector<uint8_t> memory(4096, 0xee);
    for (uint32_t layer = 0; layer < kLinearLayers; ++layer)
        for (uint32_t y = 0; y < kHeight; ++y)
            for (uint32_t x = 0; x < kWidth; ++x)
                for (uint32_t k = 0; k < 4; ++k)
                    memory[kLinearBind + layer * kClientArrayPitch + y * kClientRowPitch + x * 4 + k] =
                        texel_byte(layer, x, y, k);
    return memory;
}

// Rows 0-3 from layer 0, rows 4-7 from layer 1, as the stream below copies them.
std::vector<uint8_t> expected_linear_pixels() {
    std::vector<uint8_t> v;
    for (uint32_t y = 0; y < kHeight; ++y)
        for (uint32_t x = 0; x < kWidth; ++x)
            for (uint32_t k = 0; k < 4; ++k)
                v.push_back(texel_byte(y < kHeight / 2 ? 0 : 1, x, y, k));
    return v;
}

// Sends [from, to) of `memory` as MemoryData blocks of `block` bytes: blocks that start and end
// inside rows and padding, as the layer's diff blocks do.
bool send_blocks(Client &client, const std::vector<uint8_t> &memory, size_t from, size_t to, size_t block) {
    for (size_t at = from; at < to; at += block) {
        const size_t n = std::min(block, to - at);
        protocol::MemoryData m;
        m.device_id = kDevice;
        m.memory_id = kLinearMemory;
        m.offset = at;
        m.bytes.assign(memory.begin() + at, memory.begin() + at + n);
        if (!client.send(MessageType::MemoryData, protocol::encode(m))) return false;
    }
    return true;
}

// The linear image, its layouts, its memory (part before the bind, the rest after), both layers
// copied into the swapchain image, and a verified present. Returns the pixels the agent sent back.
bool run_linear_stream(Client &client, const protocol::ImageLayouts &layouts, std::vector<uint8_t> *pixels,
                       std::string *why, bool layouts_first = true) {
    codec::Encoder e;
    encode_setup(e);
    VkDevice dev = id<VkDevice>(kDevice);
    VkImageCreateInfo info{};
    info.sType = VK_STRUCTURE_TYPE_IMAGE_CREATE_INFO;
    info.imageType = VK_IMAGE_TYPE_2D;
    info.format = VK_FORMAT_R8G8B8A8_UNORM;
    info.extent = {kWidth, kHeight, 1};
    info.mipLevels = 1;
    info.arrayLayers = kLinearLayers;
    info.samples = VK_SAMPLE_COUNT_1_BIT;
    info.tiling = VK_IMAGE_TILING_LINEAR;
    info.usage = VK_IMAGE_USAGE_TRANSFER_SRC_BIT;
    info.initialLayout = VK_IMAGE_LAYOUT_PREINITIALIZED;
    VkImage linear = id<VkImage>(kLinearImage);
    codec::encode_vkCreateImage(e, dev, &info, nullptr, &linear);
    VkMemoryAllocateInfo alloc{};
    alloc.sType = VK_STRUCTURE_TYPE_MEMORY_ALLOCATE_INFO;
    alloc.allocationSize = 4096;
    VkDeviceMemory memory = id<VkDeviceMemory>(kLinearMemory);
    codec::encode_vkAllocateMemory(e, dev, &alloc, nullptr, &memory);
    if (!client.commands(e)) return *why = "send setup", false;
    const auto send_layouts = [&] {
        return client.send(MessageType::ImageLayouts, protocol::encode(layouts));
    };
    if (layouts_first && !send_layouts()) return *why = "send layouts", false;

    const std::vector<uint8_t> bytes = client_linear_memory();
    // Before the bind the bytes wait in the agent's shadow; after it they are routed at once.
    if (!send_blocks(client, bytes, kLinearBind, kLinearBind + 150, 150)) return *why = "send", false;
    codec::encode_vkBindImageMemory(e, dev, linear, memory, kLinearBind);
    if (!client.commands(e)) return *why = "send bind", false;
    if (!send_blocks(client, bytes, kLinearBind + 150, bytes.size(), 77)) return *why = "send", false;
    // A client may also describe the image once its bytes are there: they are laid out again.
    if (!layouts_first && !send_layouts()) return *why = "send layouts", false;

    protocol::SwapchainImages sc;
    sc.device_id = kDevice;
    sc.swapchain_id = kSwapchain;
    sc.width = kWidth;
    sc.height = kHeight;
    sc.format = VK_FORMAT_R8G8B8A8_UNORM;
    sc.usage = VK_IMAGE_USAGE_COLOR_ATTACHMENT_BIT | VK_IMAGE_USAGE_TRANSFER_DST_BIT;
    sc.image_ids = {kImage};
    if (!client.send(MessageType::SwapchainImages, protocol::encode(sc))) return *why = "send", false;

    VkCommandPoolCreateInfo pool{};
    pool.sType = VK_STRUCTURE_TYPE_COMMAND_POOL_CREATE_INFO;
    VkCommandPool p = id<VkCommandPool>(kPool);
    codec::encode_vkCreateCommandPool(e, dev, &pool, nullptr, &p);
    VkCommandBufferAllocateInfo cba{};
    cba.sType = VK_STRUCTURE_TYPE_COMMAND_BUFFER_ALLOCATE_INFO;
    cba.commandPool = p;
    cba.level = VK_COMMAND_BUFFER_LEVEL_PRIMARY;
    cba.commandBufferCount = 1;
    VkCommandBuffer cb = id<VkCommandBuffer>(kCommandBuffer);
    codec::encode_vkAllocateCommandBuffers(e, dev, &cba, &cb);
    VkCommandBufferBeginInfo begin{};
    begin.sType = VK_STRUCTURE_TYPE_COMMAND_BUFFER_BEGIN_INFO;
    codec::encode_vkBeginCommandBuffer(e, cb, &begin, VK_COMMAND_BUFFER_LEVEL_PRIMARY);
    VkImageMemoryBarrier barriers[2] = {};
    for (VkImageMemoryBarrier &b : barriers) {
        b.sType = VK_STRUCTURE_TYPE_IMAGE_MEMORY_BARRIER;
        b.srcQueueFamilyIndex = b.dstQueueFamilyIndex = VK_QUEUE_FAMILY_IGNORED;
    }
    barriers[0].srcAccessMask = VK_ACCESS_HOST_WRITE_BIT;
    barriers[0].dstAccessMask = VK_ACCESS_TRANSFER_READ_BIT;
    barriers[0].oldLayout = VK_IMAGE_LAYOUT_PREINITIALIZED;
    barriers[0].newLayout = VK_IMAGE_LAYOUT_TRANSFER_SRC_OPTIMAL;
    barriers[0].image = linear;
    barriers[0].subresourceRange = {VK_IMAGE_ASPECT_COLOR_BIT, 0, 1, 0, kLinearLayers};
    barriers[1].dstAccessMask = VK_ACCESS_TRANSFER_WRITE_BIT;
    barriers[1].oldLayout = VK_IMAGE_LAYOUT_UNDEFINED;
    barriers[1].newLayout = VK_IMAGE_LAYOUT_TRANSFER_DST_OPTIMAL;
    barriers[1].image = id<VkImage>(kImage);
    barriers[1].subresourceRange = {VK_IMAGE_ASPECT_COLOR_BIT, 0, 1, 0, 1};
    codec::encode_vkCmdPipelineBarrier(e, cb, VK_PIPELINE_STAGE_HOST_BIT, VK_PIPELINE_STAGE_TRANSFER_BIT, 0,
                                       0, nullptr, 0, nullptr, 2, barriers);
    VkImageCopy regions[2] = {};
    for (uint32_t layer = 0; layer < kLinearLayers; ++layer) {
        regions[layer].srcSubresource = {VK_IMAGE_ASPECT_COLOR_BIT, 0, layer, 1};
        regions[layer].srcOffset = {0, static_cast<int32_t>(layer * kHeight / 2), 0};
        regions[layer].dstSubresource = {VK_IMAGE_ASPECT_COLOR_BIT, 0, 0, 1};
        regions[layer].dstOffset = regions[layer].srcOffset;
        regions[layer].extent = {kWidth, kHeight / 2, 1};
    }
    codec::encode_vkCmdCopyImage(e, cb, linear, VK_IMAGE_LAYOUT_TRANSFER_SRC_OPTIMAL, id<VkImage>(kImage),
                                 VK_IMAGE_LAYOUT_TRANSFER_DST_OPTIMAL, 2, regions);
    barriers[1].srcAccessMask = VK_ACCESS_TRANSFER_WRITE_BIT;
    barriers[1].dstAccessMask = 0;
    barriers[1].oldLayout = VK_IMAGE_LAYOUT_TRANSFER_DST_OPTIMAL;
    barriers[1].newLayout = VK_IMAGE_LAYOUT_PRESENT_SRC_KHR;
    codec::encode_vkCmdPipelineBarrier(e, cb, VK_PIPELINE_STAGE_TRANSFER_BIT,
                                       VK_PIPELINE_STAGE_BOTTOM_OF_PIPE_BIT, 0, 0, nullptr, 0, nullptr, 1,
                                       &barriers[1]);
    codec::encode_vkEndCommandBuffer(e, cb);
    VkSubmitInfo submit{};
    submit.sType = VK_STRUCTURE_TYPE_SUBMIT_INFO;
    submit.commandBufferCount = 1;
    submit.pCommandBuffers = &cb;
    codec::encode_vkQueueSubmit(e, id<VkQueue>(kQueue), 1, &submit, VK_NULL_HANDLE);
    if (!client.commands(e)) return *why = "send commands", false;

    protocol::FramePresent present;
    present.queue_id = kQueue;
    present.flags = protocol::kPresentVerify;
    present.images = {{kSwapchain, 0}};
    if (!client.send(MessageType::FramePresent, protocol::encode(present)))
        return *why = "send present", false;
    auto reply = client.connection->receive(60s);
    if (!reply) return *why = "no VerifyFrame: " + client.connection->close_reason(), false;
    if (reply->type != protocol::to_wire(MessageType::VerifyFrame))
        return *why = std::string("got ") + protocol::message_type_name(reply->type), false;
    auto frame = protocol::decode_verify_frame(reply->payload, 1u << 20);
    if (!frame) return *why = frame.error(), false;
    *pixels = frame->pixels;
    codec::encode_vkDestroyImage(e, dev, linear, nullptr);
    codec::encode_vkFreeMemory(e, dev, memory, nullptr);
    return client.commands(e) ? true : (*why = "send teardown", false);
}

// --- raw sockets for what the library refuses to send -------------------------------------------

int raw_connect(const Agent &agent) {
    const int fd = socket(AF_INET, SOCK_STREAM, 0);
    sockaddr_in addr{};
    addr.sin_family = AF_INET;
    addr.sin_addr.s_addr = htonl(INADDR_LOOPBACK);
    addr.sin_port = htons(agent.port());
    if (connect(fd, reinterpret_cast<sockaddr *>(&addr), sizeof(addr)) != 0) {
        close(fd);
        return -1;
    }
    return fd;
}

bool write_all(int fd, const std::vector<uint8_t> &bytes) {
    size_t done = 0;
    while (done < bytes.size()) {
        const ssize_t n = write(fd, bytes.data() + done, bytes.size() - done);
        if (n <= 0) return false;
        done += static_cast<size_t>(n);
    }
    return true;
}

// Handshake by hand: Hello as frame 1, then read the Welcome frame.
bool raw_handshake(int fd) {
    protocol::Hello hello;
    hello.capabilities = 0; // no compression: frames stay readable
    hello.codec_fingerprint = protocol::session_fingerprint(codec::kCodecFingerprint);
    if (!write_all(fd, protocol::encode_frame(protocol::to_wire(MessageType::Hello), 1,
                                              protocol::encode_hello(hello))))
        return false;
    uint8_t header[protocol::kHeaderSize];
    if (recv(fd, header, sizeof(header), MSG_WAITALL) != static_cast<ssize_t>(sizeof(header))) return false;
    const auto h =
        protocol::decode_header(std::span<const uint8_t, protocol::kHeaderSize>(header, sizeof(header)));
    std::vector<uint8_t> payload(h.payload_length);
    if (!payload.empty() &&
        recv(fd, payload.data(), payload.size(), MSG_WAITALL) != static_cast<ssize_t>(payload.size()))
        return false;
    return h.type == protocol::to_wire(MessageType::Welcome);
}

class AgentTest : public ::testing::Test {
protected:
    void SetUp() override { ASSERT_TRUE(agent_.started()) << agent_.log(); }
    // After a malformed session: its end is logged with the reason, and a new session still works.
    void expect_error_then_recovery(uint64_t session, const std::string &log_fragment,
                                    const std::string &reason = "error") {
        EXPECT_TRUE(agent_.wait_for_end(session, reason)) << agent_.log();
        EXPECT_TRUE(agent_.wait_for_log(log_fragment)) << "missing '" << log_fragment << "' in\n"
                                                       << agent_.log();
        expect_good_session(agent_, session + 1);
    }
    Agent agent_;
};

TEST_F(AgentTest, GoodStreamReplaysAndVerifies) {
    expect_good_session(agent_, 1);
    EXPECT_TRUE(agent_.wait_for_log("session 1: device created on")) << agent_.log();
    EXPECT_NE(agent_.log().find(", VK_KHR_swapchain)"), std::string::npos) << agent_.log();
    EXPECT_TRUE(agent_.wait_for_log("session 1: closed after")) << agent_.log();
    // Two sessions one after the other each get their own device.
    expect_good_session(agent_, 2);
}

TEST_F(AgentTest, LinearImageIsRelaidFromTheClientsLayout) {
    Client client;
    ASSERT_TRUE(client.connect(agent_)) << client.error;
    std::vector<uint8_t> pixels;
    std::string why;
    ASSERT_TRUE(run_linear_stream(client, client_layouts(), &pixels, &why)) << why << "\n" << agent_.log();
    // Copied 1:1 at the client's offsets, rows 1-7 would read the client's padding and other rows.
    EXPECT_EQ(pixels, expected_linear_pixels());
    client.bye();
    EXPECT_TRUE(agent_.wait_for_end(1, "closed by the client")) << agent_.log();
}

TEST_F(AgentTest, LinearImageLayoutsAfterItsBindLayTheBytesOutAgain) {
    Client client;
    ASSERT_TRUE(client.connect(agent_)) << client.error;
    std::vector<uint8_t> pixels;
    std::string why;
    ASSERT_TRUE(run_linear_stream(client, client_layouts(), &pixels, &why, false)) << why << "\n"
                                                                                   << agent_.log();
    EXPECT_EQ(pixels, expected_linear_pixels());
    client.bye();
    EXPECT_TRUE(agent_.wait_for_end(1, "closed by the client")) << agent_.log();
}

TEST_F(AgentTest, LinearImageLayoutThatCannotHoldItsRowsEndsOnlyThatSession) {
    Client client;
    ASSERT_TRUE(client.connect(agent_)) << client.error;
    auto layouts = client_layouts();
    layouts.subresources[1].row_pitch = 8; // shorter than a 16-byte row
    std::vector<uint8_t> pixels;
    std::string why;
    run_linear_stream(client, layouts, &pixels, &why);
    expect_error_then_recovery(1, "ImageLayouts: image 0xa000: the layout of mip 0, layer 1 (row pitch 8");
}

TEST_F(AgentTest, LinearImageLayoutForAnotherFormatEndsOnlyThatSession) {
    Client client;
    ASSERT_TRUE(client.connect(agent_)) << client.error;
    auto layouts = client_layouts();
    layouts.format = VK_FORMAT_B8G8R8A8_UNORM;
    std::vector<uint8_t> pixels;
    std::string why;
    run_linear_stream(client, layouts, &pixels, &why);
    expect_error_then_recovery(
        1, "ImageLayouts: image 0xa000: format, extent, mip levels or array layers differ");
}

// A client ends a session by closing its side, without waiting for the tiles of the frames it
// has presented: an unsplit one (no pass drew into its swapchain images) waits for none, so the
// agent is still replaying a backlog of presents when the connection closes. The tiles of that
// backlog have nobody to read them; that is the session's normal end, not an error (it used to end
// with "sending Tiles: connection closed").
TEST_F(AgentTest, ClosingWithPresentsInFlightEndsCleanly) {
    Client client;
    ASSERT_TRUE(client.connect(agent_)) << client.error;
    codec::Encoder e;
    encode_setup(e);
    ASSERT_TRUE(client.commands(e));
    protocol::SwapchainImages sc;
    sc.device_id = kDevice;
    sc.swapchain_id = kSwapchain;
    sc.width = kWidth;
    sc.height = kHeight;
    sc.format = VK_FORMAT_R8G8B8A8_UNORM;
    sc.usage = VK_IMAGE_USAGE_COLOR_ATTACHMENT_BIT | VK_IMAGE_USAGE_TRANSFER_DST_BIT;
    sc.image_ids = {kImage};
    ASSERT_TRUE(client.send(MessageType::SwapchainImages, protocol::encode(sc)));
    ASSERT_TRUE(client.send(MessageType::SplitConfig, protocol::encode(protocol::SplitConfig{})));
    constexpr uint64_t kPresents = 500;
    for (uint64_t frame = 0; frame < kPresents; ++frame) {
        protocol::FramePresent present;
        present.frame = frame;
        present.queue_id = kQueue;
        present.images = {{kSwapchain, 0}};
        ASSERT_TRUE(client.send(MessageType::FramePresent, protocol::encode(present)));
    }
    // The layer's close: flush, then close, no Goodbye and no wait for the agent.
    client.connection->flush(5000ms);
    client.connection->close();
    EXPECT_TRUE(agent_.wait_for_end(1, "closed by the client")) << agent_.log();
    EXPECT_EQ(agent_.log().find("] error:"), std::string::npos) << agent_.log();
    EXPECT_NE(agent_.log().find(std::to_string(kPresents) + " frames"), std::string::npos)
        << "the session did not replay every present it was sent:\n"
        << agent_.log();
}

// SPLITVK_GAZE: the agent never trusts a frame's gaze. A point outside the eye is refused by the
// decoder; a gaze that moves the foveae in a session whose SplitConfig said they are fixed is refused
// too, since its scissors shaded only the fixed foveae and a moved one would be read back unshaded.
class AgentGaze : public AgentTest {
protected:
    void present_with_gaze(const protocol::SplitConfig &config, const split::Gaze &gaze) {
        Client client;
        ASSERT_TRUE(client.connect(agent_)) << client.error;
        codec::Encoder e;
        encode_setup(e);
        ASSERT_TRUE(client.commands(e));
        protocol::SwapchainImages sc;
        sc.device_id = kDevice;
        sc.swapchain_id = kSwapchain;
        sc.width = kWidth;
        sc.height = kHeight;
        sc.format = VK_FORMAT_R8G8B8A8_UNORM;
        sc.usage = VK_IMAGE_USAGE_COLOR_ATTACHMENT_BIT | VK_IMAGE_USAGE_TRANSFER_DST_BIT;
        sc.image_ids = {kImage};
        ASSERT_TRUE(client.send(MessageType::SwapchainImages, protocol::encode(sc)));
        ASSERT_TRUE(client.send(MessageType::SplitConfig, protocol::encode(config)));
        protocol::FramePresent present;
        present.queue_id = kQueue;
        present.images = {{kSwapchain, 0}};
        present.gaze = gaze;
        ASSERT_TRUE(client.send(MessageType::FramePresent, protocol::encode(present)));
        client.connection->flush(5000ms);
    }
};

TEST_F(AgentGaze, AGazeOutsideTheEyeEndsOnlyThatSession) {
    protocol::SplitConfig config;
    config.moving_gaze = true;
    split::Gaze gaze;
    gaze.fixed = false;
    gaze.eyes[0] = {split::kGazeOne + 1, 0};
    ASSERT_NO_FATAL_FAILURE(present_with_gaze(config, gaze));
    expect_error_then_recovery(1, "gaze point (65537, 0) of eye 0 outside the eye");
}

TEST_F(AgentGaze, AMovedFoveaInAFixedSessionEndsOnlyThatSession) {
    split::Gaze gaze;
    gaze.fixed = false;
    ASSERT_NO_FATAL_FAILURE(present_with_gaze(protocol::SplitConfig{}, gaze));
    expect_error_then_recovery(1, "FramePresent 0 moves the foveae, but SplitConfig said the gaze is fixed");
}

TEST_F(AgentTest, TruncatedMessageEndsOnlyThatSession) {
    const int fd = raw_connect(agent_);
    ASSERT_GE(fd, 0);
    ASSERT_TRUE(raw_handshake(fd));
    auto frame =
        protocol::encode_frame(protocol::to_wire(MessageType::Commands), 2, std::vector<uint8_t>(100, 0));
    frame.resize(protocol::kHeaderSize + 10);
    ASSERT_TRUE(write_all(fd, frame));
    shutdown(fd, SHUT_WR);
    expect_error_then_recovery(1, "session 1: peer closed the connection in the middle of a message");
    close(fd);
}

TEST_F(AgentTest, LengthBeyondLimitEndsOnlyThatSession) {
    const int fd = raw_connect(agent_);
    ASSERT_GE(fd, 0);
    ASSERT_TRUE(raw_handshake(fd));
    protocol::MessageHeader h;
    h.payload_length = 0xFFFFFFF0u;
    h.type = protocol::to_wire(MessageType::Commands);
    h.sequence = 2;
    const auto bytes = protocol::encode_header(h);
    ASSERT_TRUE(write_all(fd, std::vector<uint8_t>(bytes.begin(), bytes.end())));
    expect_error_then_recovery(1, "session 1: protocol error");
    close(fd);
}

TEST_F(AgentTest, UnknownTypeEndsOnlyThatSession) {
    Client client;
    ASSERT_TRUE(client.connect(agent_)) << client.error;
    ASSERT_TRUE(client.connection->send(static_cast<uint16_t>(0x0200), std::vector<uint8_t>{1, 2, 3}) ==
                protocol::SendResult::Queued);
    expect_error_then_recovery(1, "unknown message type");
}

TEST_F(AgentTest, UnknownIdEndsOnlyThatSession) {
    Client client;
    ASSERT_TRUE(client.connect(agent_)) << client.error;
    codec::Encoder e;
    encode_setup(e);
    codec::encode_vkCmdFillBuffer(e, id<VkCommandBuffer>(0x777), id<VkBuffer>(kBuffer), 0, 4, 0);
    ASSERT_TRUE(client.commands(e));
    expect_error_then_recovery(1, "session 1: vkCmdFillBuffer: unknown VkCommandBuffer id 0x777");
}

TEST_F(AgentTest, WrongObjectTypeEndsOnlyThatSession) {
    Client client;
    ASSERT_TRUE(client.connect(agent_)) << client.error;
    codec::Encoder e;
    encode_setup(e);
    // The buffer's id where a command buffer belongs.
    codec::encode_vkCmdFillBuffer(e, id<VkCommandBuffer>(kBuffer), id<VkBuffer>(kBuffer), 0, 4, 0);
    ASSERT_TRUE(client.commands(e));
    expect_error_then_recovery(1, "session 1: vkCmdFillBuffer:");
    EXPECT_NE(agent_.log().find("VkBuffer"), std::string::npos) << agent_.log();
}

TEST_F(AgentTest, CommandBeforeHandshakeIsRefused) {
    const int fd = raw_connect(agent_);
    ASSERT_GE(fd, 0);
    codec::Encoder e;
    encode_setup(e);
    ASSERT_TRUE(write_all(fd, protocol::encode_frame(protocol::to_wire(MessageType::Commands), 1, e.take())));
    expect_error_then_recovery(1, "session 1: handshake failed", "handshake failed");
    close(fd);
}

TEST_F(AgentTest, ReplayErrorOfTheDriverEndsOnlyThatSession) {
    Client client;
    ASSERT_TRUE(client.connect(agent_)) << client.error;
    codec::Encoder e;
    encode_setup(e);
    // Memory data beyond the client's allocation.
    ASSERT_TRUE(client.commands(e));
    ASSERT_TRUE(client.send(MessageType::MemoryData, protocol::encode(memory_data(4090, pattern(16, 0)))));
    expect_error_then_recovery(1, "session 1: MemoryData: memory 0x5000: 16 bytes at offset 4090 exceed");
}

// Garbage after a valid command (a valid command id first, then random argument bytes): every
// session ends with a logged error, none crashes, and the listener serves the next one.
TEST_F(AgentTest, RandomCommandBytesNeverCrashASession) {
    uint64_t state = 0x9e3779b97f4a7c15ull;
    const auto next = [&state] {
        state ^= state << 13;
        state ^= state >> 7;
        state ^= state << 17;
        return state;
    };
    constexpr uint64_t kSessions = 24;
    for (uint64_t s = 1; s <= kSessions; ++s) {
        Client client;
        ASSERT_TRUE(client.connect(agent_)) << client.error;
        codec::Encoder e;
        encode_setup(e);
        std::vector<uint8_t> payload = e.take();
        const uint16_t command =
            static_cast<uint16_t>(codec::kFirstCommandId + next() % codec::kCommandCount);
        payload.push_back(static_cast<uint8_t>(command));
        payload.push_back(static_cast<uint8_t>(command >> 8));
        const size_t n = 1 + next() % 64;
        for (size_t i = 0; i < n; ++i)
            payload.push_back(static_cast<uint8_t>(next()));
        ASSERT_TRUE(client.send(MessageType::Commands, std::move(payload)));
        client.bye();
        ASSERT_TRUE(agent_.wait_for_log("session " + std::to_string(s) + " (pid", 2)) << agent_.log();
        ASSERT_TRUE(agent_.wait_for_log("ended: ", s)) << agent_.log();
    }
    EXPECT_EQ(agent_.occurrences("killed by signal"), 0u) << agent_.log();
    EXPECT_GE(agent_.occurrences("ended: error"), kSessions / 2) << agent_.log();
    expect_good_session(agent_, kSessions + 1);
    if (std::getenv("SPLITVK_TEST_SHOW_LOG")) std::fputs(agent_.log().c_str(), stdout);
}

TEST_F(AgentTest, ResidentMemoryComesBackAfterTwentySessions) {
    expect_good_session(agent_, 1); // warm up the listener
    const long before = agent_.rss_kib();
    ASSERT_GT(before, 0);
    for (uint64_t s = 2; s < 22; ++s) {
        Client client;
        ASSERT_TRUE(client.connect(agent_)) << client.error;
        codec::Encoder e;
        encode_setup(e);
        ASSERT_TRUE(client.commands(e));
        client.bye();
        ASSERT_TRUE(agent_.wait_for_end(s, "closed by the client")) << agent_.log();
    }
    const long after = agent_.rss_kib();
    EXPECT_LE(after, before + 256) << "listener VmRSS " << before << " KiB -> " << after << " KiB";
    // Every session was reaped: no zombies left.
    const std::string children = read_file("/proc/" + std::to_string(agent_.pid()) + "/task/" +
                                           std::to_string(agent_.pid()) + "/children");
    EXPECT_TRUE(children.find_first_not_of(' ') == std::string::npos) << "children: " << children;
}

TEST(AgentListener, MaxSessionsRejectsTheExtraClient) {
    Agent agent({"--max-sessions", "1"});
    ASSERT_TRUE(agent.started()) << agent.log();
    Client first;
    ASSERT_TRUE(first.connect(agent)) << first.error;
    Client second;
    EXPECT_FALSE(second.connect(agent));
    EXPECT_NE(second.error.find("full"), std::string::npos) << second.error;
    EXPECT_TRUE(agent.wait_for_end(2, "handshake failed")) << agent.log();
    first.bye();
    EXPECT_TRUE(agent.wait_for_end(1, "closed by the client")) << agent.log();
    expect_good_session(agent, 3); // room again
}

TEST(AgentListener, SigtermStopsCleanlyWithASessionOpen) {
    Agent agent;
    ASSERT_TRUE(agent.started()) << agent.log();
    Client client;
    ASSERT_TRUE(client.connect(agent)) << client.error;
    ASSERT_TRUE(agent.wait_for_log("session 1: agent_session_test")) << agent.log();
    const int status = agent.stop();
    EXPECT_TRUE(WIFEXITED(status) && WEXITSTATUS(status) == 0) << "wait status " << status;
    EXPECT_TRUE(agent.log_has_end(1, "killed by signal 15")) << agent.log();
    EXPECT_NE(agent.log().find("info: stopped"), std::string::npos) << agent.log();
}

TEST(AgentListener, ACrashedSessionLeavesTheListenerServing) {
    Agent agent;
    ASSERT_TRUE(agent.started()) << agent.log();
    Client victim;
    ASSERT_TRUE(victim.connect(agent)) << victim.error;
    Client bystander;
    ASSERT_TRUE(bystander.connect(agent)) << bystander.error;
    ASSERT_TRUE(agent.wait_for_log("session 2: agent_session_test")) << agent.log();
    const std::string l = agent.log();
    const size_t at = l.find("session 1 (pid ");
    ASSERT_NE(at, std::string::npos) << l;
    const pid_t pid = static_cast<pid_t>(std::atol(l.c_str() + at + std::strlen("session 1 (pid ")));
    ASSERT_GT(pid, 0);
    // SIGABRT stands for a crash (an assertion); unlike SIGSEGV, sanitizer builds do not catch it.
    ASSERT_EQ(kill(pid, SIGABRT), 0);
    EXPECT_TRUE(agent.wait_for_end(1, "killed by signal 6")) << agent.log();
    // The other session goes on, and new ones are served.
    std::vector<uint8_t> pixels;
    std::string why;
    ASSERT_TRUE(run_good_stream(bystander, &pixels, &why)) << why << "\n" << agent.log();
    EXPECT_EQ(pixels, expected_pixels());
    bystander.bye();
    EXPECT_TRUE(agent.wait_for_end(2, "closed by the client")) << agent.log();
    expect_good_session(agent, 3);
}

// --- the session process's confinement (server-agent/confinement.h, docs/security.md) -----------

pid_t session_pid(const Agent &agent, uint64_t session) {
    const std::string l = agent.log();
    const std::string prefix = "session " + std::to_string(session) + " (pid ";
    const size_t at = l.find(prefix);
    return at == std::string::npos ? -1 : static_cast<pid_t>(std::atol(l.c_str() + at + prefix.size()));
}

// "Uid:", "NoNewPrivs:" ... of /proc/PID/status: the first field after the name.
std::string status_field(pid_t pid, const std::string &name) {
    std::ifstream in("/proc/" + std::to_string(pid) + "/status");
    std::string line;
    while (std::getline(in, line)) {
        if (line.rfind(name + ":", 0) != 0) continue;
        std::istringstream fields(line.substr(name.size() + 1));
        std::string first;
        fields >> first;
        return first;
    }
    return {};
}

std::string log_value(const std::string &log, const std::string &prefix) {
    const size_t at = log.find(prefix);
    if (at == std::string::npos) return {};
    const size_t start = at + prefix.size();
    return log.substr(start, log.find('\n', start) - start);
}

// A real session replays and renders under the confinement: no_new_privs, the unprivileged user
// (as root), Landlock (the unit test Confinement.SessionProcessCannotOpenOutsideTheAllowedSet
// shows what it refuses); its private directory goes when it ends, the listener's at exit.
TEST(AgentConfinement, ConfinedSessionStillReplaysAndRenders) {
    Agent agent;
    ASSERT_TRUE(agent.started()) << agent.log();
    const std::string log = agent.log();
    EXPECT_TRUE(log.find("sessions run confined: no_new_privs") != std::string::npos ||
                log.find("this kernel has no Landlock") != std::string::npos)
        << log;
    const std::string base = log_value(log, "session directories under ");
    ASSERT_FALSE(base.empty()) << log;
    Client client;
    ASSERT_TRUE(client.connect(agent)) << client.error;
    ASSERT_TRUE(agent.wait_for_log("session 1: agent_session_test")) << agent.log();
    const pid_t pid = session_pid(agent, 1);
    ASSERT_GT(pid, 0) << agent.log();
    EXPECT_EQ(status_field(pid, "NoNewPrivs"), "1");
    if (geteuid() == 0) {
        const passwd *nobody = getpwnam("nobody");
        ASSERT_NE(nobody, nullptr);
        EXPECT_EQ(status_field(pid, "Uid"), std::to_string(nobody->pw_uid));
        EXPECT_EQ(status_field(pid, "Gid"), std::to_string(nobody->pw_gid));
    }
    EXPECT_TRUE(std::filesystem::is_directory(base + "/s1"));
    std::vector<uint8_t> pixels;
    std::string why;
    ASSERT_TRUE(run_good_stream(client, &pixels, &why)) << why << "\n" << agent.log();
    EXPECT_EQ(pixels, expected_pixels());
    client.bye();
    EXPECT_TRUE(agent.wait_for_end(1, "closed by the client")) << agent.log();
    EXPECT_FALSE(std::filesystem::exists(base + "/s1"));
    agent.stop();
    EXPECT_FALSE(std::filesystem::exists(base));
}

TEST(AgentConfinement, NoConfineSaysSoAndLeavesTheSessionAsItIs) {
    Agent agent({"--no-confine"});
    ASSERT_TRUE(agent.started()) << agent.log();
    EXPECT_NE(agent.log().find("--no-confine: sessions run with the agent's rights"), std::string::npos)
        << agent.log();
    Client client;
    ASSERT_TRUE(client.connect(agent)) << client.error;
    ASSERT_TRUE(agent.wait_for_log("session 1: agent_session_test")) << agent.log();
    const pid_t pid = session_pid(agent, 1);
    ASSERT_GT(pid, 0);
    EXPECT_EQ(status_field(pid, "NoNewPrivs"), status_field(getpid(), "NoNewPrivs"));
    EXPECT_EQ(status_field(pid, "Uid"), std::to_string(geteuid()));
    client.bye();
    EXPECT_TRUE(agent.wait_for_end(1, "closed by the client")) << agent.log();
}

TEST(AgentToken, BadTokenIsRejectedAndTheRightOneWorks) {
    Agent agent({"--token-file", "TOKEN_FILE"});
    ASSERT_TRUE(agent.started()) << agent.log();
    Client bad;
    EXPECT_FALSE(bad.connect(agent, "wrong-token"));
    EXPECT_NE(bad.error.find("bad token"), std::string::npos) << bad.error;
    EXPECT_TRUE(agent.wait_for_end(1, "handshake failed")) << agent.log();
    Client good;
    ASSERT_TRUE(good.connect(agent, "right-token")) << good.error;
    std::vector<uint8_t> pixels;
    std::string why;
    ASSERT_TRUE(run_good_stream(good, &pixels, &why)) << why << "\n" << agent.log();
    EXPECT_EQ(pixels, expected_pixels());
    good.bye();
    EXPECT_TRUE(agent.wait_for_end(2, "closed by the client")) << agent.log();
}

TEST(AgentValidate, GoodStreamHasNoValidationMessages) {
    if (!std::ifstream("/usr/share/vulkan/explicit_layer.d/VkLayer_khronos_validation.json"))
        GTEST_SKIP() << "vulkan-validationlayers is not installed";
    Agent agent({"--validate"});
    ASSERT_TRUE(agent.started()) << agent.log();
    EXPECT_NE(agent.log().find("validation on"), std::string::npos);
    expect_good_session(agent, 1);
    EXPECT_TRUE(agent.wait_for_log("session 1: closed after")) << agent.log();
    EXPECT_NE(agent.log().find("; 0 validation errors, 0 validation warnings;"), std::string::npos)
        << agent.log();
    EXPECT_EQ(agent.log().find("validation: "), std::string::npos) << agent.log();
    if (std::getenv("SPLITVK_TEST_SHOW_LOG")) std::fputs(agent.log().c_str(), stdout);
}

// --- limits (docs/security.md): going over one ends only that session, with one line naming it --

void encode_allocate(codec::Encoder &e, uint64_t memory, VkDeviceSize size) {
    VkMemoryAllocateInfo alloc{};
    alloc.sType = VK_STRUCTURE_TYPE_MEMORY_ALLOCATE_INFO;
    alloc.allocationSize = size;
    VkDeviceMemory m = id<VkDeviceMemory>(memory);
    codec::encode_vkAllocateMemory(e, id<VkDevice>(kDevice), &alloc, nullptr, &m);
}

// A bystander session is open while `offend` breaks a cap in session 2; the bystander then runs
// the good stream to the end, and a fresh session (3) works too.
template <class Offend>
void expect_cap_ends_only_that_session(Agent &agent, const std::string &log_fragment, Offend offend) {
    ASSERT_TRUE(agent.started()) << agent.log();
    Client bystander;
    ASSERT_TRUE(bystander.connect(agent)) << bystander.error;
    Client offender;
    ASSERT_TRUE(offender.connect(agent)) << offender.error;
    ASSERT_TRUE(agent.wait_for_log("session 2: agent_session_test")) << agent.log();
    offend(offender);
    EXPECT_TRUE(agent.wait_for_end(2, "error")) << agent.log();
    EXPECT_TRUE(agent.wait_for_log(log_fragment)) << "missing '" << log_fragment << "' in\n" << agent.log();
    EXPECT_EQ(agent.occurrences(log_fragment), 1u) << agent.log();
    std::vector<uint8_t> pixels;
    std::string why;
    ASSERT_TRUE(run_good_stream(bystander, &pixels, &why)) << why << "\n" << agent.log();
    EXPECT_EQ(pixels, expected_pixels());
    bystander.bye();
    EXPECT_TRUE(agent.wait_for_end(1, "closed by the client")) << agent.log();
    expect_good_session(agent, 3);
    if (std::getenv("SPLITVK_TEST_SHOW_LOG")) std::fputs(agent.log().c_str(), stdout);
}

TEST(AgentLimits, MessageOverMaxMessageBytesEndsOnlyThatSession) {
    Agent agent({"--max-message-bytes", "64K"});
    // Incompressible bytes, so the cap is met on the wire (the compressed case is checked on the
    // decompressed size, with the same flag in the line).
    expect_cap_ends_only_that_session(agent, "(--max-message-bytes)", [](Client &c) {
        std::vector<uint8_t> big(100 << 10);
        uint32_t x = 12345;
        for (auto &b : big)
            b = static_cast<uint8_t>((x = x * 1103515245u + 12345u) >> 24);
        c.send(MessageType::MemoryData, protocol::encode(memory_data(0, std::move(big))));
    });
}

TEST(AgentLimits, CompressedMessageOverMaxMessageBytesEndsOnlyThatSession) {
    Agent agent({"--max-message-bytes", "64K"});
    expect_cap_ends_only_that_session(agent, "--max-message-bytes", [](Client &c) {
        c.send(MessageType::MemoryData, protocol::encode(memory_data(0, std::vector<uint8_t>(1 << 20, 7))));
    });
}

TEST(AgentLimits, AllocationsOverMaxGpuMemoryEndOnlyThatSession) {
    Agent agent({"--max-gpu-memory", "1M"});
    expect_cap_ends_only_that_session(agent, "over --max-gpu-memory (1048576 bytes)", [](Client &c) {
        codec::Encoder e;
        encode_setup(e);                          // 4096 bytes
        encode_allocate(e, kMemory + 1, 1 << 19); // 512 KiB: fits
        encode_allocate(e, kMemory + 2, 1 << 19); // over 1 MiB in all
        c.commands(e);
    });
}

TEST(AgentLimits, ResourcesBoundOverMaxGpuMemoryEndOnlyThatSession) {
    // The client's allocation is small; the buffer bound to it asks the agent for more.
    Agent agent({"--max-gpu-memory", "1M"});
    expect_cap_ends_only_that_session(agent, "over --max-gpu-memory (1048576 bytes)", [](Client &c) {
        codec::Encoder e;
        encode_setup(e);
        VkBufferCreateInfo buffer{};
        buffer.sType = VK_STRUCTURE_TYPE_BUFFER_CREATE_INFO;
        buffer.size = 4 << 20;
        buffer.usage = VK_BUFFER_USAGE_TRANSFER_SRC_BIT;
        VkBuffer b = id<VkBuffer>(kBuffer + 1);
        codec::encode_vkCreateBuffer(e, id<VkDevice>(kDevice), &buffer, nullptr, &b);
        codec::encode_vkBindBufferMemory(e, id<VkDevice>(kDevice), b, id<VkDeviceMemory>(kMemory), 0);
        c.commands(e);
    });
}

TEST(AgentLimits, SwapchainImagesOverMaxGpuMemoryEndOnlyThatSession) {
    // The offscreen images that stand for a swapchain's are device memory too.
    Agent agent({"--max-gpu-memory", "1M"});
    expect_cap_ends_only_that_session(agent, "over --max-gpu-memory (1048576 bytes)", [](Client &c) {
        codec::Encoder e;
        encode_setup(e);
        c.commands(e);
        protocol::SwapchainImages sc;
        sc.device_id = kDevice;
        sc.swapchain_id = kSwapchain;
        sc.width = 1024;
        sc.height = 1024;
        sc.format = VK_FORMAT_B8G8R8A8_UNORM;
        sc.usage = VK_IMAGE_USAGE_COLOR_ATTACHMENT_BIT;
        sc.image_ids = {kImage, kImage + 1, kImage + 2};
        c.send(MessageType::SwapchainImages, protocol::encode(sc));
    });
}

TEST(AgentLimits, ShadowsOverMaxHostMemoryEndOnlyThatSession) {
    Agent agent({"--max-host-memory", "1M"});
    expect_cap_ends_only_that_session(agent, "over --max-host-memory (1048576 bytes)", [](Client &c) {
        codec::Encoder e;
        encode_setup(e);
        encode_allocate(e, kMemory + 1, 8 << 20);
        c.commands(e);
        // Not bound to anything: kept in the session's shadow until a bind. Two messages, the
        // second one over.
        for (uint64_t offset : {uint64_t{0}, uint64_t{1} << 20}) {
            protocol::MemoryData m = memory_data(offset, pattern(768 << 10, 3));
            m.memory_id = kMemory + 1;
            c.send(MessageType::MemoryData, protocol::encode(m));
        }
    });
}

// --listen on anything but loopback without --token-file: one line, exit status 2, no listening.
TEST(AgentToken, NonLoopbackWithoutTokenIsRefused) {
    char path[] = "/tmp/splitvk-agent-token-XXXXXX";
    const int fd = mkstemp(path);
    ASSERT_GE(fd, 0);
    const pid_t pid = fork();
    if (pid == 0) {
        dup2(fd, STDERR_FILENO);
        execl(SPLITVK_AGENT_BINARY, SPLITVK_AGENT_BINARY, "--listen", "0.0.0.0:7447",
              static_cast<char *>(nullptr));
        _exit(127);
    }
    close(fd);
    int status = 0;
    ASSERT_EQ(waitpid(pid, &status, 0), pid);
    const std::string log = read_file(path);
    std::remove(path);
    EXPECT_TRUE(WIFEXITED(status) && WEXITSTATUS(status) == 2) << "wait status " << status << "\n" << log;
    EXPECT_NE(log.find("refusing to listen on non-loopback address 0.0.0.0 without --token-file"),
              std::string::npos)
        << log;
    EXPECT_EQ(std::count(log.begin(), log.end(), '\n'), 1) << log;
    EXPECT_EQ(log.find("listening on"), std::string::npos) << log;
}

// --emulate-limits with a file it cannot use: one line naming the file and what is wrong, exit
// status 2, no listening. A typo in a limit's name must not pass as "no constraint".
TEST(AgentEmulateLimits, UnusableProfileIsOneLineAndNoListening) {
    char profile[] = "/tmp/splitvk-agent-profile-XXXXXX";
    const int profile_fd = mkstemp(profile);
    ASSERT_GE(profile_fd, 0);
    const std::string bad =
        R"({"capabilities":{"gpu":{"properties":{"VkPhysicalDeviceProperties":{"limits":{"maxImageDimensoin2D":4096}}}}}})";
    ASSERT_EQ(write(profile_fd, bad.data(), bad.size()), static_cast<ssize_t>(bad.size()));
    close(profile_fd);
    for (const auto &[file, expected] :
         {std::pair<std::string, std::string>{"/nonexistent/strict.json", "cannot read it"},
          std::pair<std::string, std::string>{profile,
                                              "capability gpu: unknown limit 'maxImageDimensoin2D'"}}) {
        char path[] = "/tmp/splitvk-agent-log-XXXXXX";
        const int fd = mkstemp(path);
        ASSERT_GE(fd, 0);
        const pid_t pid = fork();
        if (pid == 0) {
            dup2(fd, STDERR_FILENO);
            execl(SPLITVK_AGENT_BINARY, SPLITVK_AGENT_BINARY, "--listen", "127.0.0.1:7449",
                  "--emulate-limits", file.c_str(), static_cast<char *>(nullptr));
            _exit(127);
        }
        close(fd);
        int status = 0;
        ASSERT_EQ(waitpid(pid, &status, 0), pid);
        const std::string log = read_file(path);
        std::remove(path);
        EXPECT_TRUE(WIFEXITED(status) && WEXITSTATUS(status) == 2) << "wait status " << status << "\n" << log;
        EXPECT_NE(log.find("--emulate-limits " + file + ": " + expected), std::string::npos) << log;
        EXPECT_EQ(std::count(log.begin(), log.end(), '\n'), 1) << log;
        EXPECT_EQ(log.find("listening on"), std::string::npos) << log;
    }
    std::remove(profile);
}

// --record-corpus: the seeds scripts/fuzz records. Every file is a stream that starts at
// sequence 1, the Hello without its token, the stream of the session in order.
TEST(AgentRecordCorpus, WritesSeedsWithoutTheToken) {
    char dir[] = "/tmp/splitvk-agent-corpus-XXXXXX";
    ASSERT_NE(mkdtemp(dir), nullptr);
    {
        Agent agent({"--token-file", "TOKEN_FILE", "--record-corpus", dir});
        ASSERT_TRUE(agent.started()) << agent.log();
        EXPECT_NE(agent.log().find("--record-corpus"), std::string::npos) << agent.log();
        Client client;
        ASSERT_TRUE(client.connect(agent, "right-token")) << client.error;
        std::vector<uint8_t> pixels;
        std::string why;
        ASSERT_TRUE(run_good_stream(client, &pixels, &why)) << why << "\n" << agent.log();
        client.bye();
        EXPECT_TRUE(agent.wait_for_end(1, "closed by the client")) << agent.log();
    }
    const std::string prefix = std::string(dir) + "/s1-";
    const std::string hello = read_file(prefix + "hello");
    ASSERT_GE(hello.size(), protocol::kHeaderSize);
    EXPECT_EQ(hello.find("right-token"), std::string::npos);
    const std::string stream = read_file(prefix + "stream");
    ASSERT_GE(stream.size(), protocol::kHeaderSize);
    const auto first = protocol::decode_header(std::span<const uint8_t, protocol::kHeaderSize>(
        reinterpret_cast<const uint8_t *>(stream.data()), protocol::kHeaderSize));
    EXPECT_EQ(first.sequence, 1u);
    EXPECT_EQ(first.type, protocol::to_wire(MessageType::Commands));
    EXPECT_FALSE(read_file(prefix + "0000-Vulkan_command").empty());
    // A whole recorded stream frames cleanly.
    protocol::FrameDecoder frames;
    std::vector<protocol::Message> messages;
    EXPECT_TRUE(frames.feed({reinterpret_cast<const uint8_t *>(stream.data()), stream.size()}, messages))
        << frames.error();
    EXPECT_GE(messages.size(), 3u);
    EXPECT_TRUE(frames.at_message_boundary());
    std::filesystem::remove_all(dir);
}

// --- the swapped split: the agent renders the periphery -------------------------------

// A 64x32 window image the client fills from a buffer with a smooth picture; the agent replays it
// whole and sends the image downsampled to scale 0.5 as the two periphery parts, lossily.
constexpr uint32_t kPeripheryWidth = 64, kPeripheryHeight = 32;
constexpr uint64_t kPictureBuffer = 0x4100, kPictureMemory = 0x5100;

uint8_t picture_byte(uint32_t x, uint32_t y, uint32_t k) {
    switch (k) {
    case 0:
        return static_cast<uint8_t>(x * 4);
    case 1:
        return static_cast<uint8_t>(y * 8);
    case 2:
        return static_cast<uint8_t>(40 + (x + y) * 2);
    default:
        return 255;
    }
}

// A command buffer (client id `command_buffer`) that copies the picture from `picture` into the
// swapchain image, left for present, and its submit.
bool encode_picture_frame(codec::Encoder &e, VkCommandPool pool, VkBuffer picture, uint64_t command_buffer) {
    VkDevice dev = id<VkDevice>(kDevice);
    VkCommandBufferAllocateInfo cba{};
    cba.sType = VK_STRUCTURE_TYPE_COMMAND_BUFFER_ALLOCATE_INFO;
    cba.commandPool = pool;
    cba.level = VK_COMMAND_BUFFER_LEVEL_PRIMARY;
    cba.commandBufferCount = 1;
    VkCommandBuffer cb = id<VkCommandBuffer>(command_buffer);
    codec::encode_vkAllocateCommandBuffers(e, dev, &cba, &cb);
    VkCommandBufferBeginInfo begin{};
    begin.sType = VK_STRUCTURE_TYPE_COMMAND_BUFFER_BEGIN_INFO;
    codec::encode_vkBeginCommandBuffer(e, cb, &begin, VK_COMMAND_BUFFER_LEVEL_PRIMARY);
    VkImageMemoryBarrier ib{};
    ib.sType = VK_STRUCTURE_TYPE_IMAGE_MEMORY_BARRIER;
    ib.dstAccessMask = VK_ACCESS_TRANSFER_WRITE_BIT;
    ib.oldLayout = VK_IMAGE_LAYOUT_UNDEFINED;
    ib.newLayout = VK_IMAGE_LAYOUT_TRANSFER_DST_OPTIMAL;
    ib.srcQueueFamilyIndex = ib.dstQueueFamilyIndex = VK_QUEUE_FAMILY_IGNORED;
    ib.image = id<VkImage>(kImage);
    ib.subresourceRange = {VK_IMAGE_ASPECT_COLOR_BIT, 0, 1, 0, 1};
    // After the host's write of the picture, and after the previous frame's present (the agent's
    // blit reads the image then) as an application's acquire semaphore would order it.
    codec::encode_vkCmdPipelineBarrier(e, cb, VK_PIPELINE_STAGE_HOST_BIT | VK_PIPELINE_STAGE_TRANSFER_BIT,
                                       VK_PIPELINE_STAGE_TRANSFER_BIT, 0, 0, nullptr, 0, nullptr, 1, &ib);
    VkBufferImageCopy region{};
    region.imageSubresource = {VK_IMAGE_ASPECT_COLOR_BIT, 0, 0, 1};
    region.imageExtent = {kPeripheryWidth, kPeripheryHeight, 1};
    codec::encode_vkCmdCopyBufferToImage(e, cb, picture, id<VkImage>(kImage),
                                         VK_IMAGE_LAYOUT_TRANSFER_DST_OPTIMAL, 1, &region);
    ib.srcAccessMask = VK_ACCESS_TRANSFER_WRITE_BIT;
    ib.dstAccessMask = 0;
    ib.oldLayout = VK_IMAGE_LAYOUT_TRANSFER_DST_OPTIMAL;
    ib.newLayout = VK_IMAGE_LAYOUT_PRESENT_SRC_KHR;
    codec::encode_vkCmdPipelineBarrier(e, cb, VK_PIPELINE_STAGE_TRANSFER_BIT,
                                       VK_PIPELINE_STAGE_BOTTOM_OF_PIPE_BIT, 0, 0, nullptr, 0, nullptr, 1,
                                       &ib);
    codec::encode_vkEndCommandBuffer(e, cb);
    VkSubmitInfo submit{};
    submit.sType = VK_STRUCTURE_TYPE_SUBMIT_INFO;
    submit.commandBufferCount = 1;
    submit.pCommandBuffers = &cb;
    codec::encode_vkQueueSubmit(e, id<VkQueue>(kQueue), 1, &submit, VK_NULL_HANDLE);
    return true;
}

// The setup, the swapchain, SplitConfig and (unless `config` is null) PeripheryConfig, then `frames`
// frames that each copy the picture into the swapchain image (a command buffer each) and present it.
bool run_periphery_stream(Client &client, const protocol::PeripheryConfig *config, bool periphery_first,
                          std::string *why, uint32_t frames = 1) {
    codec::Encoder e;
    encode_setup(e);
    VkDevice dev = id<VkDevice>(kDevice);
    constexpr VkDeviceSize kBytes = VkDeviceSize{kPeripheryWidth} * kPeripheryHeight * 4;
    VkBufferCreateInfo buffer{};
    buffer.sType = VK_STRUCTURE_TYPE_BUFFER_CREATE_INFO;
    buffer.size = kBytes;
    buffer.usage = VK_BUFFER_USAGE_TRANSFER_SRC_BIT;
    VkBuffer b = id<VkBuffer>(kPictureBuffer);
    codec::encode_vkCreateBuffer(e, dev, &buffer, nullptr, &b);
    VkMemoryAllocateInfo alloc{};
    alloc.sType = VK_STRUCTURE_TYPE_MEMORY_ALLOCATE_INFO;
    alloc.allocationSize = kBytes;
    VkDeviceMemory m = id<VkDeviceMemory>(kPictureMemory);
    codec::encode_vkAllocateMemory(e, dev, &alloc, nullptr, &m);
    codec::encode_vkBindBufferMemory(e, dev, b, m, 0);
    if (!client.commands(e)) return *why = "send setup", false;
    protocol::MemoryData picture;
    picture.device_id = kDevice;
    picture.memory_id = kPictureMemory;
    for (uint32_t y = 0; y < kPeripheryHeight; ++y)
        for (uint32_t x = 0; x < kPeripheryWidth; ++x)
            for (uint32_t k = 0; k < 4; ++k)
                picture.bytes.push_back(picture_byte(x, y, k));
    if (!client.send(MessageType::MemoryData, protocol::encode(picture))) return *why = "send", false;

    protocol::SwapchainImages sc;
    sc.device_id = kDevice;
    sc.swapchain_id = kSwapchain;
    sc.width = kPeripheryWidth;
    sc.height = kPeripheryHeight;
    sc.format = VK_FORMAT_R8G8B8A8_UNORM;
    sc.usage = VK_IMAGE_USAGE_COLOR_ATTACHMENT_BIT | VK_IMAGE_USAGE_TRANSFER_DST_BIT;
    sc.image_ids = {kImage};
    if (!client.send(MessageType::SwapchainImages, protocol::encode(sc))) return *why = "send", false;
    const auto send_periphery = [&] {
        return !config || client.send(MessageType::PeripheryConfig, protocol::encode(*config));
    };
    if (periphery_first && !send_periphery()) return *why = "send", false;
    if (!client.send(MessageType::SplitConfig, protocol::encode(protocol::SplitConfig{})))
        return *why = "send", false;
    if (!periphery_first && !send_periphery()) return *why = "send", false;

    VkCommandPoolCreateInfo pool{};
    pool.sType = VK_STRUCTURE_TYPE_COMMAND_POOL_CREATE_INFO;
    VkCommandPool p = id<VkCommandPool>(kPool);
    codec::encode_vkCreateCommandPool(e, dev, &pool, nullptr, &p);
    for (uint32_t frame = 0; frame < frames; ++frame) {
        if (!encode_picture_frame(e, p, b, kCommandBuffer + frame) || !client.commands(e))
            return *why = "send commands", false;
        protocol::FramePresent present;
        present.frame = frame;
        present.queue_id = kQueue;
        present.images = {{kSwapchain, 0}};
        if (!client.send(MessageType::FramePresent, protocol::encode(present)))
            return *why = "send present", false;
    }
    return true;
}

// The picture downsampled 2:1 as a linear blit does it: each pixel the mean of a 2x2 block.
std::vector<uint8_t> picture_halved() {
    std::vector<uint8_t> v;
    for (uint32_t y = 0; y < kPeripheryHeight / 2; ++y)
        for (uint32_t x = 0; x < kPeripheryWidth / 2; ++x)
            for (uint32_t k = 0; k < 4; ++k) {
                uint32_t sum = 0;
                for (uint32_t dy = 0; dy < 2; ++dy)
                    for (uint32_t dx = 0; dx < 2; ++dx)
                        sum += picture_byte(2 * x + dx, 2 * y + dy, k);
                v.push_back(static_cast<uint8_t>((sum + 2) / 4));
            }
    return v;
}

double psnr_rgb(const std::vector<uint8_t> &expected, const std::vector<uint8_t> &actual) {
    double squared = 0;
    size_t count = 0;
    for (size_t i = 0; i < expected.size(); ++i) {
        if (i % 4 == 3) continue;
        const double d = static_cast<double>(expected[i]) - static_cast<double>(actual[i]);
        squared += d * d;
        ++count;
    }
    return squared == 0 ? 99 : 10 * std::log10(255.0 * 255.0 * static_cast<double>(count) / squared);
}

// A session in the swapped split: two frames, each answered with the two periphery parts of the
// picture downsampled to 0.5, which decode (lossily: a fovea decoder refuses them) to the picture
// halved, the second frame's from the first's stream.
void expect_periphery_session(Agent &agent, uint64_t session, PeripheryCodec codec = PeripheryCodec::H264) {
    SCOPED_TRACE(to_string(codec));
    Client client;
    ASSERT_TRUE(client.connect(agent)) << client.error;
    EXPECT_TRUE(client.granted & protocol::capability::kSwappedSplit);
    const protocol::PeripheryConfig config{0.5, {false, 23}, false, codec};
    constexpr uint32_t kFrames = 2;
    std::string why;
    ASSERT_TRUE(run_periphery_stream(client, &config, false, &why, kFrames)) << why << "\n" << agent.log();
    const VkExtent2D scaled = split::scaled_extent({kPeripheryWidth, kPeripheryHeight}, config.scale);
    ASSERT_EQ(scaled.width, kPeripheryWidth / 2);
    const auto parts = split::periphery_parts(scaled);
    std::vector<std::unique_ptr<tiles::TileDecoder>> decoders(parts.size());
    for (uint32_t frame = 0; frame < kFrames; ++frame) {
        std::optional<protocol::Tiles> tiles;
        while (!tiles) {
            auto reply = client.connection->receive(60s);
            ASSERT_TRUE(reply) << "no Tiles: " << client.connection->close_reason() << "\n" << agent.log();
            if (reply->type != protocol::to_wire(MessageType::Tiles)) continue;
            auto decoded = protocol::decode_tiles(reply->payload, 1u << 20);
            ASSERT_TRUE(decoded.ok()) << decoded.error();
            tiles = std::move(*decoded);
        }
        EXPECT_EQ(tiles->frame, frame);
        EXPECT_EQ(tiles->swapchain_id, kSwapchain);
        EXPECT_EQ(tiles->flags, 0u);
        ASSERT_EQ(tiles->tiles.size(), parts.size()) << agent.log();
        std::vector<uint8_t> image(size_t{scaled.width} * scaled.height * 4);
        for (size_t i = 0; i < parts.size(); ++i) {
            const protocol::EncodedTile &tile = tiles->tiles[i];
            EXPECT_EQ(tile.flags, (frame == 0 ? protocol::kTileKeyframe : 0u) | protocol::kTilePeriphery);
            EXPECT_EQ(tile.codec, split::periphery_tile_codec(codec));
            ASSERT_EQ(tile.x, static_cast<uint32_t>(parts[i].offset.x));
            ASSERT_EQ(tile.y, static_cast<uint32_t>(parts[i].offset.y));
            ASSERT_EQ(tile.width, parts[i].extent.width);
            ASSERT_EQ(tile.height, parts[i].extent.height);
            std::string error;
            std::vector<uint8_t> pixels(size_t{tile.width} * tile.height * 4);
            if (frame == 0) {
                // A fovea's decoder refuses a lossy part (a 4:2:0 codec has none at all).
                auto strict = tiles::make_tile_decoder(tile.codec, tile.width, tile.height, 4, &error);
                if (strict) {
                    EXPECT_FALSE(strict->decode(tile.data, pixels.data(), &error)) << "a lossy part, refused";
                }
                decoders[i] = tiles::make_tile_decoder(tile.codec, tile.width, tile.height, 4, &error, true);
                ASSERT_NE(decoders[i], nullptr) << error;
            }
            ASSERT_TRUE(decoders[i]->decode(tile.data, pixels.data(), &error)) << error;
            for (uint32_t y = 0; y < tile.height; ++y)
                std::copy_n(pixels.begin() + size_t{y} * tile.width * 4, size_t{tile.width} * 4,
                            image.begin() + ((size_t{tile.y} + y) * scaled.width + tile.x) * 4);
        }
        EXPECT_GT(psnr_rgb(picture_halved(), image), 35.0)
            << "frame " << frame << ": the periphery is not the picture downsampled";
    }
    client.bye();
    EXPECT_TRUE(agent.wait_for_end(session, "closed by the client")) << agent.log();
    EXPECT_EQ(agent.occurrences("session " + std::to_string(session) + ": the swapped split"), 1u)
        << agent.log();
}

TEST_F(AgentTest, SwappedSplitSendsTheDownsampledPeriphery) {
    expect_periphery_session(agent_, 1);
}

// SPLITVK_PERIPHERY_CODEC travels in PeripheryConfig: each codec's parts come in it.
TEST_F(AgentTest, SwappedSplitSendsThePeripheryInTheCodecAskedFor) {
    expect_periphery_session(agent_, 1, PeripheryCodec::Hevc);
    expect_periphery_session(agent_, 2, PeripheryCodec::Rgb);
}

TEST(AgentValidate, SwappedSplitHasNoValidationMessages) {
    if (!std::ifstream("/usr/share/vulkan/explicit_layer.d/VkLayer_khronos_validation.json"))
        GTEST_SKIP() << "vulkan-validationlayers is not installed";
    Agent agent({"--validate"});
    ASSERT_TRUE(agent.started()) << agent.log();
    expect_periphery_session(agent, 1);
    EXPECT_TRUE(agent.wait_for_log("session 1: closed after")) << agent.log();
    EXPECT_NE(agent.log().find("; 0 validation errors, 0 validation warnings;"), std::string::npos)
        << agent.log();
    EXPECT_EQ(agent.log().find("validation: "), std::string::npos) << agent.log();
}

TEST_F(AgentTest, PeripheryConfigBeforeSplitConfigEndsOnlyThatSession) {
    Client client;
    ASSERT_TRUE(client.connect(agent_)) << client.error;
    const protocol::PeripheryConfig config{0.5, {false, 23}};
    std::string why;
    run_periphery_stream(client, &config, true, &why);
    client.connection->flush(5000ms);
    expect_error_then_recovery(1, "PeripheryConfig before SplitConfig");
}

TEST(AgentPeriphery, NoPeripheryRefusesTheSwappedSplit) {
    Agent agent({"--no-periphery"});
    ASSERT_TRUE(agent.started()) << agent.log();
    Client client;
    ASSERT_TRUE(client.connect(agent)) << client.error;
    EXPECT_FALSE(client.granted & protocol::capability::kSwappedSplit) << "not granted";
    const protocol::PeripheryConfig config{0.5, {false, 23}};
    std::string why;
    run_periphery_stream(client, &config, false, &why);
    client.connection->flush(5000ms);
    EXPECT_TRUE(agent.wait_for_end(1, "error")) << agent.log();
    EXPECT_TRUE(agent.wait_for_log("PeripheryConfig without capability kSwappedSplit")) << agent.log();
    expect_good_session(agent, 2);
}

// --- images whose format or size is not what the tiles were sized for ----------------------------

// A `width`x`height` swapchain image of `format` filled from a buffer with texel_value() bytes, and
// `frames` presents of it (verified with `verify`). With `runtime`, the image is the client's own
// vkCreateImage of `runtime_image` (an OpenXR runtime's), adopted under a declared `format`,
// extent and `declared_layers`, with an eye in each declared layer (SwapchainView).
struct FormatStream {
    VkFormat format = VK_FORMAT_R16G16B16A16_UNORM;
    uint32_t width = 48, height = 32;
    uint32_t frames = 1;
    bool verify = false;
    bool runtime = false;
    VkImageCreateInfo runtime_image{}; // with `runtime`: what the image is
    uint32_t declared_layers = 1;
};

constexpr uint64_t kFormatImageMemory = 0x5200, kSourceImage = 0x9100, kSourceMemory = 0x5300;

uint8_t texel_value(uint32_t x, uint32_t y, uint32_t k) {
    return static_cast<uint8_t>(x * 5 + y * 11 + k * 37 + 3);
}

uint32_t block_bytes(VkFormat format) {
    return format_info(format).block_bytes;
}

bool run_format_stream(Client &client, const FormatStream &f, std::string *why) {
    codec::Encoder e;
    encode_setup(e);
    VkDevice dev = id<VkDevice>(kDevice);
    // The buffer holds the image as it is: a runtime image's own format and extent.
    const VkFormat image_format = f.runtime ? f.runtime_image.format : f.format;
    const uint32_t image_width = f.runtime ? f.runtime_image.extent.width : f.width;
    const uint32_t image_height = f.runtime ? f.runtime_image.extent.height : f.height;
    const VkDeviceSize bytes = VkDeviceSize{image_width} * image_height * block_bytes(image_format);
    VkBufferCreateInfo buffer{};
    buffer.sType = VK_STRUCTURE_TYPE_BUFFER_CREATE_INFO;
    buffer.size = bytes;
    buffer.usage = VK_BUFFER_USAGE_TRANSFER_SRC_BIT;
    VkBuffer b = id<VkBuffer>(kPictureBuffer);
    codec::encode_vkCreateBuffer(e, dev, &buffer, nullptr, &b);
    VkMemoryAllocateInfo alloc{};
    alloc.sType = VK_STRUCTURE_TYPE_MEMORY_ALLOCATE_INFO;
    alloc.allocationSize = bytes;
    VkDeviceMemory m = id<VkDeviceMemory>(kPictureMemory);
    codec::encode_vkAllocateMemory(e, dev, &alloc, nullptr, &m);
    codec::encode_vkBindBufferMemory(e, dev, b, m, 0);
    // The picture goes to the swapchain image through an image of its own: a copy from an image into
    // a swapchain image is drawing into it (its foveae are read back), as the layer notes it.
    VkImageCreateInfo source_info = f.runtime_image;
    source_info.sType = VK_STRUCTURE_TYPE_IMAGE_CREATE_INFO;
    source_info.imageType = VK_IMAGE_TYPE_2D;
    source_info.format = image_format;
    source_info.extent = {image_width, image_height, 1};
    source_info.mipLevels = 1;
    source_info.arrayLayers = 1;
    source_info.samples = VK_SAMPLE_COUNT_1_BIT;
    source_info.tiling = VK_IMAGE_TILING_OPTIMAL;
    source_info.usage = VK_IMAGE_USAGE_TRANSFER_DST_BIT | VK_IMAGE_USAGE_TRANSFER_SRC_BIT;
    VkImage source = id<VkImage>(kSourceImage);
    codec::encode_vkCreateImage(e, dev, &source_info, nullptr, &source);
    alloc.allocationSize = 1 << 20;
    VkDeviceMemory sm = id<VkDeviceMemory>(kSourceMemory);
    codec::encode_vkAllocateMemory(e, dev, &alloc, nullptr, &sm);
    codec::encode_vkBindImageMemory(e, dev, source, sm, 0);
    if (f.runtime) {
        VkImage image = id<VkImage>(kImage);
        codec::encode_vkCreateImage(e, dev, &f.runtime_image, nullptr, &image);
        VkDeviceMemory im = id<VkDeviceMemory>(kFormatImageMemory);
        codec::encode_vkAllocateMemory(e, dev, &alloc, nullptr, &im);
        codec::encode_vkBindImageMemory(e, dev, image, im, 0);
    }
    if (!client.commands(e)) return *why = "send setup", false;
    protocol::MemoryData picture;
    picture.device_id = kDevice;
    picture.memory_id = kPictureMemory;
    for (uint32_t y = 0; y < image_height; ++y)
        for (uint32_t x = 0; x < image_width; ++x)
            for (uint32_t k = 0; k < block_bytes(image_format); ++k)
                picture.bytes.push_back(texel_value(x, y, k));
    if (!client.send(MessageType::MemoryData, protocol::encode(picture))) return *why = "send", false;

    protocol::SwapchainImages sc;
    sc.device_id = kDevice;
    sc.swapchain_id = kSwapchain;
    sc.width = f.width;
    sc.height = f.height;
    sc.format = f.format;
    sc.array_layers = f.declared_layers;
    sc.usage = VK_IMAGE_USAGE_COLOR_ATTACHMENT_BIT | VK_IMAGE_USAGE_TRANSFER_DST_BIT;
    sc.image_ids = {kImage};
    if (f.runtime) sc.source = protocol::SwapchainImages::Source::Runtime;
    if (!client.send(MessageType::SwapchainImages, protocol::encode(sc))) return *why = "send", false;
    for (uint32_t layer = 0; f.runtime && layer < f.declared_layers; ++layer) {
        protocol::SwapchainView view{kDevice, kSwapchain, -0.8f, 0.8f,    0.8f,    -0.8f,
                                     layer,   0,          0,     f.width, f.height};
        if (!client.send(MessageType::SwapchainView, protocol::encode(view))) return *why = "send", false;
    }
    if (!client.send(MessageType::SplitConfig, protocol::encode(protocol::SplitConfig{})))
        return *why = "send", false;

    VkCommandPoolCreateInfo pool{};
    pool.sType = VK_STRUCTURE_TYPE_COMMAND_POOL_CREATE_INFO;
    VkCommandPool p = id<VkCommandPool>(kPool);
    codec::encode_vkCreateCommandPool(e, dev, &pool, nullptr, &p);
    for (uint32_t frame = 0; frame < f.frames; ++frame) {
        VkCommandBufferAllocateInfo cba{};
        cba.sType = VK_STRUCTURE_TYPE_COMMAND_BUFFER_ALLOCATE_INFO;
        cba.commandPool = p;
        cba.level = VK_COMMAND_BUFFER_LEVEL_PRIMARY;
        cba.commandBufferCount = 1;
        VkCommandBuffer cb = id<VkCommandBuffer>(kCommandBuffer + frame);
        codec::encode_vkAllocateCommandBuffers(e, dev, &cba, &cb);
        VkCommandBufferBeginInfo begin{};
        begin.sType = VK_STRUCTURE_TYPE_COMMAND_BUFFER_BEGIN_INFO;
        codec::encode_vkBeginCommandBuffer(e, cb, &begin, VK_COMMAND_BUFFER_LEVEL_PRIMARY);
        VkImageMemoryBarrier ib[2] = {};
        for (VkImageMemoryBarrier &barrier : ib) {
            barrier.sType = VK_STRUCTURE_TYPE_IMAGE_MEMORY_BARRIER;
            barrier.dstAccessMask = VK_ACCESS_TRANSFER_WRITE_BIT;
            barrier.oldLayout = VK_IMAGE_LAYOUT_UNDEFINED;
            barrier.newLayout = VK_IMAGE_LAYOUT_TRANSFER_DST_OPTIMAL;
            barrier.srcQueueFamilyIndex = barrier.dstQueueFamilyIndex = VK_QUEUE_FAMILY_IGNORED;
            barrier.subresourceRange = {VK_IMAGE_ASPECT_COLOR_BIT, 0, 1, 0, VK_REMAINING_ARRAY_LAYERS};
        }
        ib[0].image = id<VkImage>(kImage);
        ib[1].image = id<VkImage>(kSourceImage);
        codec::encode_vkCmdPipelineBarrier(e, cb, VK_PIPELINE_STAGE_HOST_BIT | VK_PIPELINE_STAGE_TRANSFER_BIT,
                                           VK_PIPELINE_STAGE_TRANSFER_BIT, 0, 0, nullptr, 0, nullptr, 2, ib);
        VkBufferImageCopy region{};
        region.imageSubresource = {VK_IMAGE_ASPECT_COLOR_BIT, 0, 0, 1};
        region.imageExtent = {image_width, image_height, 1};
        codec::encode_vkCmdCopyBufferToImage(e, cb, b, id<VkImage>(kSourceImage),
                                             VK_IMAGE_LAYOUT_TRANSFER_DST_OPTIMAL, 1, &region);
        ib[1].srcAccessMask = VK_ACCESS_TRANSFER_WRITE_BIT;
        ib[1].dstAccessMask = VK_ACCESS_TRANSFER_READ_BIT;
        ib[1].oldLayout = VK_IMAGE_LAYOUT_TRANSFER_DST_OPTIMAL;
        ib[1].newLayout = VK_IMAGE_LAYOUT_TRANSFER_SRC_OPTIMAL;
        codec::encode_vkCmdPipelineBarrier(e, cb, VK_PIPELINE_STAGE_TRANSFER_BIT,
                                           VK_PIPELINE_STAGE_TRANSFER_BIT, 0, 0, nullptr, 0, nullptr, 1,
                                           &ib[1]);
        VkImageCopy copy{};
        copy.srcSubresource = copy.dstSubresource = {VK_IMAGE_ASPECT_COLOR_BIT, 0, 0, 1};
        copy.extent = {image_width, image_height, 1};
        codec::encode_vkCmdCopyImage(e, cb, id<VkImage>(kSourceImage), VK_IMAGE_LAYOUT_TRANSFER_SRC_OPTIMAL,
                                     id<VkImage>(kImage), VK_IMAGE_LAYOUT_TRANSFER_DST_OPTIMAL, 1, &copy);
        ib[0].srcAccessMask = VK_ACCESS_TRANSFER_WRITE_BIT;
        ib[0].dstAccessMask = 0;
        ib[0].oldLayout = VK_IMAGE_LAYOUT_TRANSFER_DST_OPTIMAL;
        ib[0].newLayout = VK_IMAGE_LAYOUT_PRESENT_SRC_KHR;
        codec::encode_vkCmdPipelineBarrier(e, cb, VK_PIPELINE_STAGE_TRANSFER_BIT,
                                           VK_PIPELINE_STAGE_BOTTOM_OF_PIPE_BIT, 0, 0, nullptr, 0, nullptr, 1,
                                           &ib[0]);
        codec::encode_vkEndCommandBuffer(e, cb);
        VkSubmitInfo submit{};
        submit.sType = VK_STRUCTURE_TYPE_SUBMIT_INFO;
        submit.commandBufferCount = 1;
        submit.pCommandBuffers = &cb;
        codec::encode_vkQueueSubmit(e, id<VkQueue>(kQueue), 1, &submit, VK_NULL_HANDLE);
        if (!client.commands(e)) return *why = "send commands", false;
        protocol::FramePresent present;
        present.frame = frame;
        present.queue_id = kQueue;
        present.flags = f.verify ? protocol::kPresentVerify : 0;
        present.images = {{kSwapchain, 0}};
        if (!client.send(MessageType::FramePresent, protocol::encode(present)))
            return *why = "send present", false;
    }
    return true;
}

// The Tiles and VerifyFrame messages of `frames` frames, in the order each kind came (a frame's
// VerifyFrame leaves with its present, its Tiles when encoded); false when they do not all come.
struct Replies {
    std::vector<protocol::Tiles> tiles;
    std::vector<protocol::VerifyFrame> verify;
};
bool collect(Client &client, uint32_t frames, bool verify, Replies *out, std::string *why) {
    while (out->tiles.size() < frames || (verify && out->verify.size() < frames)) {
        auto reply = client.connection->receive(60s);
        if (!reply) return *why = "no reply: " + client.connection->close_reason(), false;
        if (reply->type == protocol::to_wire(MessageType::Tiles)) {
            auto tiles = protocol::decode_tiles(reply->payload, 1u << 20);
            if (!tiles) return *why = tiles.error(), false;
            out->tiles.push_back(std::move(*tiles));
        } else if (reply->type == protocol::to_wire(MessageType::VerifyFrame)) {
            auto frame = protocol::decode_verify_frame(reply->payload, 1u << 20);
            if (!frame) return *why = frame.error(), false;
            out->verify.push_back(std::move(*frame));
        }
    }
    return true;
}

// An RGBA16 window image (as xrgears' eye images are): its foveae are read back at 8 bytes a texel
// and travel with zstd though the session asked for x264, each tile decoding to the image's bytes
// exactly; verification reads the whole image back at 8 bytes a texel too.
TEST_F(AgentTest, EightByteImagesTravelLosslesslyWithZstd) {
    Client client;
    ASSERT_TRUE(client.connect(agent_)) << client.error;
    FormatStream f;
    f.frames = 2;
    f.verify = true;
    std::string why;
    ASSERT_TRUE(run_format_stream(client, f, &why)) << why << "\n" << agent_.log();
    Replies replies;
    ASSERT_TRUE(collect(client, f.frames, true, &replies, &why)) << why << "\n" << agent_.log();
    std::vector<std::unique_ptr<tiles::TileDecoder>> decoders;
    for (uint32_t frame = 0; frame < f.frames; ++frame) {
        const protocol::Tiles *tiles = &replies.tiles[frame];
        EXPECT_EQ(tiles->frame, frame);
        EXPECT_EQ(tiles->flags, 0u);
        EXPECT_EQ(tiles->format, static_cast<uint32_t>(VK_FORMAT_R16G16B16A16_UNORM));
        ASSERT_FALSE(tiles->tiles.empty()) << agent_.log();
        decoders.resize(tiles->tiles.size());
        for (size_t i = 0; i < tiles->tiles.size(); ++i) {
            const protocol::EncodedTile &tile = tiles->tiles[i];
            EXPECT_EQ(tile.codec, TileCodec::Zstd);
            ASSERT_EQ(tiles::peek_texel_bytes(tile.data), 8u);
            std::string error;
            if (!decoders[i])
                decoders[i] = tiles::make_tile_decoder(tile.codec, tile.width, tile.height, 8, &error);
            ASSERT_NE(decoders[i], nullptr) << error;
            std::vector<uint8_t> pixels(size_t{tile.width} * tile.height * 8);
            ASSERT_TRUE(decoders[i]->decode(tile.data, pixels.data(), &error)) << error;
            for (uint32_t y = 0; y < tile.height; ++y)
                for (uint32_t x = 0; x < tile.width; ++x)
                    for (uint32_t k = 0; k < 8; ++k)
                        ASSERT_EQ(pixels[(size_t{y} * tile.width + x) * 8 + k],
                                  texel_value(tile.x + x, tile.y + y, k))
                            << "tile " << i << " at " << x << "," << y << " byte " << k;
        }
        const protocol::VerifyFrame *whole = &replies.verify[frame];
        ASSERT_EQ(whole->pixels.size(), size_t{f.width} * f.height * 8);
        EXPECT_EQ(whole->pixels[(size_t{7} * f.width + 5) * 8 + 6], texel_value(5, 7, 6));
    }
    client.bye();
    EXPECT_TRUE(agent_.wait_for_end(1, "closed by the client")) << agent_.log();
    EXPECT_EQ(agent_.occurrences("VK_FORMAT_R16G16B16A16_UNORM has 8-byte texels, which x264 does not take"),
              1u)
        << agent_.log();
    EXPECT_EQ(agent_.log().find("] error:"), std::string::npos) << agent_.log();
}

// A 16-byte format (RGBA32F) is no format tiles carry: nothing is read back, each frame's Tiles is
// invalid (the client shows its periphery), and it is said once.
TEST_F(AgentTest, SixteenByteImagesAreNotReadBackAndTheirTilesAreInvalid) {
    Client client;
    ASSERT_TRUE(client.connect(agent_)) << client.error;
    FormatStream f;
    f.format = VK_FORMAT_R32G32B32A32_SFLOAT;
    f.frames = 3;
    f.verify = true;
    std::string why;
    ASSERT_TRUE(run_format_stream(client, f, &why)) << why << "\n" << agent_.log();
    Replies replies;
    ASSERT_TRUE(collect(client, f.frames, false, &replies, &why)) << why << "\n" << agent_.log();
    for (uint32_t frame = 0; frame < f.frames; ++frame) {
        const protocol::Tiles *tiles = &replies.tiles[frame];
        EXPECT_EQ(tiles->frame, frame);
        EXPECT_EQ(tiles->flags, protocol::kTilesInvalid);
        EXPECT_TRUE(tiles->tiles.empty());
    }
    client.bye();
    EXPECT_TRUE(agent_.wait_for_end(1, "closed by the client")) << agent_.log();
    EXPECT_EQ(agent_.occurrences("VK_FORMAT_R32G32B32A32_SFLOAT is not a format tiles carry"), 1u)
        << agent_.log();
    EXPECT_EQ(agent_.occurrences("verification skips the images of VK_FORMAT_R32G32B32A32_SFLOAT"), 1u)
        << agent_.log();
}

// An OpenXR runtime's image that is not what the client declared: smaller, in one layer where two
// were declared, and 8 bytes a texel where 4 were. The eyes the client placed in the declared
// layers lie outside the image: nothing is read back from it (the over-write the wrong sizes would
// have made), the frame's Tiles are invalid, and the session goes on to its normal end.
TEST_F(AgentTest, ARuntimeImageUnlikeItsDeclarationIsNotReadBeyond) {
    Client client;
    ASSERT_TRUE(client.connect(agent_)) << client.error;
    FormatStream f;
    f.format = VK_FORMAT_R8G8B8A8_UNORM;
    f.width = 64;
    f.height = 32;
    f.declared_layers = 2;
    f.frames = 2;
    f.verify = true;
    f.runtime = true;
    f.runtime_image.sType = VK_STRUCTURE_TYPE_IMAGE_CREATE_INFO;
    f.runtime_image.imageType = VK_IMAGE_TYPE_2D;
    f.runtime_image.format = VK_FORMAT_R16G16B16A16_UNORM;
    f.runtime_image.extent = {16, 8, 1};
    f.runtime_image.mipLevels = 1;
    f.runtime_image.arrayLayers = 1;
    f.runtime_image.samples = VK_SAMPLE_COUNT_1_BIT;
    f.runtime_image.tiling = VK_IMAGE_TILING_OPTIMAL;
    f.runtime_image.usage = VK_IMAGE_USAGE_COLOR_ATTACHMENT_BIT | VK_IMAGE_USAGE_TRANSFER_DST_BIT |
                            VK_IMAGE_USAGE_TRANSFER_SRC_BIT;
    std::string why;
    ASSERT_TRUE(run_format_stream(client, f, &why)) << why << "\n" << agent_.log();
    Replies replies;
    ASSERT_TRUE(collect(client, f.frames, true, &replies, &why)) << why << "\n" << agent_.log();
    for (uint32_t frame = 0; frame < f.frames; ++frame) {
        const protocol::Tiles *tiles = &replies.tiles[frame];
        EXPECT_EQ(tiles->flags, protocol::kTilesInvalid) << agent_.log();
        EXPECT_TRUE(tiles->tiles.empty());
        // Verification reads the image as it is: 16x8 at 8 bytes, its one layer.
        const protocol::VerifyFrame *whole = &replies.verify[frame];
        EXPECT_EQ(whole->width, 16u);
        EXPECT_EQ(whole->layers, 1u);
        EXPECT_EQ(whole->format, static_cast<uint32_t>(VK_FORMAT_R16G16B16A16_UNORM));
        ASSERT_EQ(whole->pixels.size(), size_t{16} * 8 * 8);
        EXPECT_EQ(whole->pixels[(size_t{3} * 16 + 9) * 8 + 2], texel_value(9, 3, 2));
    }
    client.bye();
    EXPECT_TRUE(agent_.wait_for_end(1, "closed by the client")) << agent_.log();
    EXPECT_EQ(agent_.occurrences("its images are VK_FORMAT_R16G16B16A16_UNORM 16x8 in 1 layer(s), the client "
                                 "declared VK_FORMAT_R8G8B8A8_UNORM 64x32 in 2 layer(s)"),
              1u)
        << agent_.log();
    EXPECT_EQ(agent_.occurrences("is outside the image (16x8 in 1 layer(s))"), 1u) << agent_.log();
}

// A window swapchain of a format no window presents (depth, or a value vk.xml does not list) is
// refused before the driver makes images of it: one line, and only that session ends.
TEST_F(AgentTest, AWindowSwapchainOfNoColourFormatEndsOnlyThatSession) {
    Client client;
    ASSERT_TRUE(client.connect(agent_)) << client.error;
    codec::Encoder e;
    encode_setup(e);
    ASSERT_TRUE(client.commands(e));
    protocol::SwapchainImages sc;
    sc.device_id = kDevice;
    sc.swapchain_id = kSwapchain;
    sc.width = kWidth;
    sc.height = kHeight;
    sc.format = 0x7ffffff0;
    sc.usage = VK_IMAGE_USAGE_COLOR_ATTACHMENT_BIT;
    sc.image_ids = {kImage};
    ASSERT_TRUE(client.send(MessageType::SwapchainImages, protocol::encode(sc)));
    client.connection->flush(5000ms);
    expect_error_then_recovery(
        1, "an unknown VkFormat (VkFormat 2147483632) is not a colour format a window presents");
}

// The client closes while the agent is still sending it tiles it will never read: its kernel
// resets the connection, and the agent's send or read meets the reset. That is the client's close,
// as a clean one is (it used to end the session with "sending Tiles: connection closed").
TEST_F(AgentTest, AClientThatResetsWhileTilesAreSentEndsCleanly) {
    const int fd = raw_connect(agent_);
    ASSERT_GE(fd, 0);
    ASSERT_TRUE(raw_handshake(fd));
    uint32_t sequence = 2;
    const auto send_message = [&](MessageType type, const std::vector<uint8_t> &payload) {
        return write_all(fd, protocol::encode_frame(protocol::to_wire(type), sequence++, payload));
    };
    codec::Encoder e;
    encode_setup(e);
    ASSERT_TRUE(send_message(MessageType::Commands, e.take()));
    protocol::SwapchainImages sc;
    sc.device_id = kDevice;
    sc.swapchain_id = kSwapchain;
    sc.width = 512;
    sc.height = 512;
    sc.format = VK_FORMAT_R16G16B16A16_UNORM;
    sc.usage = VK_IMAGE_USAGE_COLOR_ATTACHMENT_BIT | VK_IMAGE_USAGE_TRANSFER_DST_BIT;
    sc.image_ids = {kImage};
    ASSERT_TRUE(send_message(MessageType::SwapchainImages, protocol::encode(sc)));
    protocol::SplitConfig split;
    split.codec = TileCodec::Raw; // large tiles: the socket's buffers fill at once
    ASSERT_TRUE(send_message(MessageType::SplitConfig, protocol::encode(split)));
    // Each present asks for the whole image back: its tiles fill the socket, which this client
    // never reads.
    constexpr uint64_t kPresents = 60;
    for (uint64_t frame = 0; frame < kPresents; ++frame) {
        protocol::FramePresent present;
        present.frame = frame;
        present.queue_id = kQueue;
        present.flags = protocol::kPresentVerify;
        present.images = {{kSwapchain, 0}};
        ASSERT_TRUE(send_message(MessageType::FramePresent, protocol::encode(present)));
    }
    ASSERT_TRUE(agent_.wait_for_log("session 1: first frame submitted")) << agent_.log();
    std::this_thread::sleep_for(200ms);
    linger abort_now{1, 0};
    ASSERT_EQ(setsockopt(fd, SOL_SOCKET, SO_LINGER, &abort_now, sizeof(abort_now)), 0);
    close(fd);
    EXPECT_TRUE(agent_.wait_for_end(1, "closed by the client")) << agent_.log();
    EXPECT_EQ(agent_.log().find("] error:"), std::string::npos) << agent_.log();
}

} // namespace
