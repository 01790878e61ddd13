"""What splitvk forwards: core Vulkan 1.0-1.3 and these extensions, nothing else.

The layer hides every other device extension from the application (GFXReconstruct does the
same), because a command the agent cannot replay would silently desynchronise the two sides.
Adding an extension here is a promise that its commands and structures are forwarded.
"""
import re

CORE_VERSIONS = r"VK_VERSION_1_[0-3]"

# Instance extensions: window-system integration and debugging. They carry no rendering state
# the agent needs, apart from the surface, which the agent replaces with offscreen images.
INSTANCE_EXTENSIONS = [
    "VK_KHR_surface",
    "VK_KHR_xcb_surface",
    "VK_KHR_xlib_surface",
    "VK_KHR_wayland_surface",
    "VK_KHR_get_physical_device_properties2",
    "VK_KHR_get_surface_capabilities2",
    "VK_KHR_surface_protected_capabilities",
    "VK_KHR_external_memory_capabilities",
    "VK_KHR_external_semaphore_capabilities",
    "VK_KHR_external_fence_capabilities",
    "VK_KHR_device_group_creation",
    "VK_KHR_portability_enumeration",
    "VK_EXT_swapchain_colorspace",
    "VK_EXT_debug_utils",
    "VK_EXT_debug_report",
]

# Device extensions: the swapchain, and extensions promoted to core 1.1-1.3 that apps still
# enable by their KHR/EXT names, plus dynamic state the split rewrite itself relies on.
DEVICE_EXTENSIONS = [
    "VK_KHR_swapchain",
    "VK_KHR_incremental_present",
    "VK_KHR_multiview",
    "VK_KHR_maintenance1",
    "VK_KHR_maintenance2",
    "VK_KHR_maintenance3",
    "VK_KHR_maintenance4",
    "VK_KHR_bind_memory2",
    "VK_KHR_get_memory_requirements2",
    "VK_KHR_dedicated_allocation",
    "VK_KHR_descriptor_update_template",
    "VK_KHR_push_descriptor",
    "VK_KHR_create_renderpass2",
    "VK_KHR_depth_stencil_resolve",
    "VK_KHR_dynamic_rendering",
    "VK_KHR_synchronization2",
    "VK_KHR_timeline_semaphore",
    "VK_KHR_copy_commands2",
    "VK_KHR_draw_indirect_count",
    "VK_KHR_shader_draw_parameters",
    "VK_KHR_sampler_mirror_clamp_to_edge",
    "VK_KHR_sampler_ycbcr_conversion",
    "VK_KHR_image_format_list",
    "VK_KHR_imageless_framebuffer",
    "VK_KHR_separate_depth_stencil_layouts",
    "VK_KHR_uniform_buffer_standard_layout",
    "VK_KHR_shader_float16_int8",
    "VK_KHR_16bit_storage",
    "VK_KHR_8bit_storage",
    "VK_KHR_storage_buffer_storage_class",
    "VK_KHR_relaxed_block_layout",
    "VK_KHR_driver_properties",
    "VK_KHR_format_feature_flags2",
    "VK_KHR_shader_non_semantic_info",
    "VK_KHR_shader_terminate_invocation",
    "VK_KHR_zero_initialize_workgroup_memory",
    "VK_EXT_descriptor_indexing",
    "VK_EXT_host_query_reset",
    "VK_EXT_scalar_block_layout",
    "VK_EXT_separate_stencil_usage",
    "VK_EXT_sampler_filter_minmax",
    "VK_EXT_extended_dynamic_state",
    "VK_EXT_extended_dynamic_state2",
    "VK_EXT_index_type_uint8",
    "VK_EXT_vertex_attribute_divisor",
    "VK_EXT_shader_demote_to_helper_invocation",
    "VK_EXT_subgroup_size_control",
    "VK_EXT_inline_uniform_block",
    "VK_EXT_pipeline_creation_feedback",
    "VK_EXT_private_data",
    "VK_EXT_texel_buffer_alignment",
    "VK_EXT_image_robustness",
    "VK_EXT_robustness2",
    "VK_EXT_4444_formats",
    "VK_EXT_depth_clip_enable",
    "VK_EXT_custom_border_color",
    "VK_EXT_line_rasterization",
    "VK_EXT_tooling_info",
] + [
    # Buffer device addresses (core 1.2's bufferDeviceAddress by its extension name). The agent's
    # addresses are not the client's: the layer sends what vkGetBufferDeviceAddress returned, and
    # the agent translates the addresses it can see (server-agent/buffer_addresses.h). The
    # capture/replay and multi-device features stay hidden (layer/core/physical_device.cpp).
    "VK_KHR_buffer_device_address",
] + [
    # Sharing memory, semaphores and fences with another process: what an OpenXR runtime's client
    # compositor needs on the application's device (Monado imports its eye images with opaque fds;
    # docs/architecture.md §9). CLIENT_ONLY_EXTENSIONS says what the agent does with them.
    "VK_KHR_external_memory",
    "VK_KHR_external_memory_fd",
    "VK_KHR_external_semaphore",
    "VK_KHR_external_semaphore_fd",
    "VK_KHR_external_fence",
    "VK_KHR_external_fence_fd",
] + [
    # What modern engines enable at startup (DXVK, vkd3d-proton, Godot 4, Unreal, Unity).
    # Recorded state the agent replays like any other vkCmd*. None of it is screen-space: the
    # conditional-rendering predicate and the transform-feedback buffers and counters live in
    # buffers each side writes with its own GPU from the same commands (vertex data, not pixels),
    # and the EDS3 states are per-pipeline rasterization and blend state, not viewports or scissors
    # (the layer's viewport rewrite covers every command that sets those).
    "VK_EXT_conditional_rendering",
    "VK_EXT_transform_feedback",
    "VK_EXT_extended_dynamic_state3",  # the subset WITHHELD_FEATURES leaves
    "VK_EXT_color_write_enable",
    "VK_EXT_vertex_input_dynamic_state",
    # Pipeline, sampler and image-view state carried in structures and flags the codec forwards.
    "VK_EXT_provoking_vertex",
    "VK_EXT_depth_clip_control",
    "VK_EXT_depth_range_unrestricted",
    "VK_EXT_border_color_swizzle",
    "VK_EXT_non_seamless_cube_map",
    "VK_EXT_image_2d_view_of_3d",
    "VK_EXT_primitive_topology_list_restart",
    "VK_EXT_pipeline_creation_cache_control",
    "VK_EXT_attachment_feedback_loop_layout",
    "VK_EXT_rasterization_order_attachment_access",
    "VK_ARM_rasterization_order_attachment_access",
    # Queries and timestamps: answered by the client's driver (codec_policy.py). Primitives
    # generated count vertices, not pixels, so the scaled periphery does not change them.
    "VK_EXT_primitives_generated_query",
    "VK_EXT_calibrated_timestamps",
    # Shader capabilities only: the SPIR-V crosses the wire as it is, and the features that gate
    # them are mirrored on the agent's device like every other feature of the client's chain.
    "VK_EXT_post_depth_coverage",
    "VK_EXT_shader_atomic_float",
    "VK_EXT_shader_atomic_float2",
    "VK_EXT_shader_stencil_export",
    "VK_EXT_shader_subgroup_ballot",
    "VK_EXT_shader_subgroup_vote",
    "VK_EXT_shader_viewport_index_layer",  # every viewport is scaled alike, whichever a shader picks
    "VK_GOOGLE_decorate_string",
    "VK_GOOGLE_hlsl_functionality1",
    "VK_KHR_shader_atomic_int64",
    "VK_KHR_shader_clock",
    "VK_KHR_shader_float_controls",
    "VK_KHR_shader_integer_dot_product",
    "VK_KHR_shader_subgroup_extended_types",
    "VK_KHR_spirv_1_4",
    "VK_KHR_variable_pointers",
    "VK_KHR_vulkan_memory_model",
]

# Members of forwarded extensions' feature structures that the layer always reports as
# unsupported: the state they enable belongs to extensions splitvk withholds (so no application
# can use it validly through splitvk), or has no forwarded meaning. The layer clears them in every
# VkPhysicalDeviceFeatures2 answer (layer/core/physical_device.cpp). Reason per member.
WITHHELD_FEATURES = {
    "VkPhysicalDeviceExtendedDynamicState3FeaturesEXT": {
        "extendedDynamicState3ConservativeRasterizationMode": "VK_EXT_conservative_rasterization is withheld",
        "extendedDynamicState3ExtraPrimitiveOverestimationSize": "VK_EXT_conservative_rasterization is withheld",
        "extendedDynamicState3SampleLocationsEnable": "VK_EXT_sample_locations is withheld",
        "extendedDynamicState3ColorBlendAdvanced": "VK_EXT_blend_operation_advanced is withheld",
        "extendedDynamicState3ViewportWScalingEnable": "VK_NV_clip_space_w_scaling is withheld",
        "extendedDynamicState3ViewportSwizzle": "VK_NV_viewport_swizzle is withheld",
        "extendedDynamicState3CoverageToColorEnable": "VK_NV_fragment_coverage_to_color is withheld",
        "extendedDynamicState3CoverageToColorLocation": "VK_NV_fragment_coverage_to_color is withheld",
        "extendedDynamicState3CoverageModulationMode": "VK_NV_framebuffer_mixed_samples is withheld",
        "extendedDynamicState3CoverageModulationTableEnable": "VK_NV_framebuffer_mixed_samples is withheld",
        "extendedDynamicState3CoverageModulationTable": "VK_NV_framebuffer_mixed_samples is withheld",
        "extendedDynamicState3CoverageReductionMode": "VK_NV_coverage_reduction_mode is withheld",
        "extendedDynamicState3RepresentativeFragmentTestEnable": "VK_NV_representative_fragment_test is withheld",
        "extendedDynamicState3ShadingRateImageEnable": "VK_NV_shading_rate_image is withheld",
    },
}

# Why each device extension that vk.xml knows and lavapipe (Debian 12's Mesa) offers is not in
# DEVICE_EXTENSIONS. The Coverage test (tests/e2e/suites/unsupported_test.cpp) prints this table
# beside the number, and fails on a withheld extension without a reason here.
WITHHELD_REASONS = {
    "VK_KHR_device_group": "one GPU on each side: no device masks or peer memory to replay",
    "VK_EXT_graphics_pipeline_library":
        "pipeline libraries are linked from parts the agent would have to keep and relink in order",
    "VK_KHR_pipeline_library": "only a base for VK_EXT_graphics_pipeline_library",
    "VK_EXT_external_memory_host": "host pointers name memory of the client's process",
    "VK_EXT_multisampled_render_to_single_sampled":
        "implicit multisampled attachments the layer's scaled render areas and resolves do not model",
    "VK_KHR_swapchain_mutable_format":
        "swapchain images viewed in a second format, which the agent's offscreen swapchain images are not made for",
    "VK_EXT_multi_draw":
        "pVertexInfo is a strided array (vk.xml's stride=), which the generated codec does not encode yet",
}

# Forwarded device extensions that only the client's device enables: the agent has no other
# process to share with. Their commands are answered by the client's driver (codec_policy.py), and
# their structures never cross the wire (codec_overrides.DROPPED_EXTENSIONS), so the agent replays
# an imported or exportable image as an ordinary one. The agent never enables these, whatever the
# client's vkCreateDevice named.
CLIENT_ONLY_EXTENSIONS = {
    "VK_KHR_external_memory_fd": "an fd names a file of the client's process",
    "VK_KHR_external_semaphore_fd": "the agent drops every semaphore of a submit (submit_rules.h)",
    "VK_KHR_external_fence_fd": "the agent's fences are its own",
}


def extension_regex() -> str:
    names = sorted(INSTANCE_EXTENSIONS + DEVICE_EXTENSIONS)
    return "^(" + "|".join(re.escape(n) for n in names) + ")$"
