// The layer's per-handle state belongs to the device whose handle it is (device.h): a table made
// with each DeviceState and freed with it. The image table (image.cpp) stands for them all here:
// a non-dispatchable handle names an object of one device only (Vulkan lets another device's
// object have the same value), and once a device is gone, the driver may hand the values of its
// objects to those of the next device, which must start with state of their own.
#include "core/image.h"

#include <memory>

#include <gtest/gtest.h>

namespace splitvk {
// DeviceState owns a std::unique_ptr<Session>; the image table never touches the session, so a
// complete (empty) type is all this binary needs to destroy a DeviceState.
class Session {};

namespace {

template <class Handle>
Handle handle(uint64_t value) {
    return reinterpret_cast<Handle>(value);
}

std::unique_ptr<DeviceState> make_device() {
    auto device = std::make_unique<DeviceState>();
    device->images = make_image_table();
    return device;
}

// A screen-space target as vkCreateImage records it (resource.cpp): scaled, created by the layer.
ImageState screen_space_target(DeviceState &device, VkExtent2D full) {
    ImageState state;
    state.device = &device;
    state.created = true;
    state.screen_space = true;
    state.full = full;
    state.extent = {full.width / 2, full.height / 2, 1};
    state.layouts.assign(1, VK_IMAGE_LAYOUT_UNDEFINED);
    return state;
}

TEST(DeviceTables, AnImageIsLookedUpOnItsOwnDevice) {
    const auto a = make_device(), b = make_device();
    const VkImage image = handle<VkImage>(0x1000);
    add_image(*a, image, screen_space_target(*a, {640, 480}));
    add_image(*b, image, screen_space_target(*b, {320, 240}));

    VkExtent2D full{};
    ASSERT_TRUE(read_image(*a, image, [&](const ImageState &s) { full = s.full; }));
    EXPECT_EQ(full.width, 640u);
    ASSERT_TRUE(read_image(*b, image, [&](const ImageState &s) { full = s.full; }));
    EXPECT_EQ(full.width, 320u);

    // One device's destroy leaves the other's image alone.
    remove_image(*a, image);
    EXPECT_FALSE(read_image(*a, image, [](const ImageState &) {}));
    EXPECT_TRUE(read_image(*b, image, [](const ImageState &) {}));
    size_t count = 0;
    for_each_image(*b, [&](VkImage, const ImageState &) { ++count; });
    EXPECT_EQ(count, 1u);
}

TEST(DeviceTables, ADestroyedDevicesImagesDoNotLingerIntoTheNextDevice) {
    const VkImage image = handle<VkImage>(0x2000);
    auto first = make_device();
    // The application destroys the device with the image still alive: its state goes with it.
    add_image(*first, image, screen_space_target(*first, {640, 480}));
    const std::weak_ptr<ImageTable> table = first->images;
    first.reset();
    EXPECT_TRUE(table.expired());

    // The next device's swapchain image gets the value the driver freed: a plain swapchain image,
    // not the first device's scaled target (whose state would scale every pass into it).
    const auto second = make_device();
    const VkSwapchainKHR swapchain = handle<VkSwapchainKHR>(0x3000);
    note_swapchain_images(*second, swapchain, 1, &image);
    bool found = false;
    read_image(*second, image, [&](const ImageState &s) {
        found = true;
        EXPECT_EQ(s.device, second.get());
        EXPECT_FALSE(s.created);
        EXPECT_FALSE(s.screen_space);
        EXPECT_EQ(s.swapchain, swapchain);
    });
    EXPECT_TRUE(found);

    // Its destroy takes the image out with it, as for any swapchain image the layer did not create.
    forget_swapchain_images(*second, swapchain, 1, &image);
    EXPECT_FALSE(read_image(*second, image, [](const ImageState &) {}));
}

TEST(DeviceTables, SubmitsLockOnlyTheirOwnDevicesImages) {
    const auto a = make_device(), b = make_device();
    const VkImage image = handle<VkImage>(0x4000);
    add_image(*a, image, screen_space_target(*a, {64, 64}));
    LockedImages locked(*a);
    ImageState *state = locked.find(image);
    ASSERT_NE(state, nullptr);
    state->layout(0, 0) = VK_IMAGE_LAYOUT_GENERAL;
    // Another device's table is not held by `locked`: reading it does not wait.
    EXPECT_FALSE(read_image(*b, image, [](const ImageState &) {}));
}

} // namespace
} // namespace splitvk
