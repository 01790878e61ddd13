// splitvk beside the layers users already run: MangoHud and the Mesa overlay, each
// above splitvk and below it, in the order the documented recipe (docs/user-guide.md, "Using
// splitvk with other layers") gives with Debian's loader 1.3.239:
//   - implicit layers are always above explicit ones, in the order their manifests are found
//     (XDG_DATA_DIRS order for the build tree's and /usr/share's implicit folders);
//   - explicit layers named in VK_INSTANCE_LAYERS are chained in the order their manifests are
//     found, not in the variable's order: one folder per layer in VK_LAYER_PATH, top first.
// The order is read from the loader's own call stack (VK_LOADER_DEBUG=layer) and the recipe is
// checked both ways, so it is the folders that decide and not chance.
//
// Every run has validation (synchronization validation on) below splitvk and a real agent run
// with --validate; splitvk-atrium's foveae must equal native bit for bit where splitvk is the top
// layer (below an overlay they hold its HUD's pixels only where the HUD is, which is outside the
// foveae, but that is the overlay's business and not asserted).
#include "agent.h"
#include "e2e_test.h"
#include "fovea.h"

#include <algorithm>
#include <fstream>
#include <thread>

namespace splitvk::e2e {
namespace {

using namespace std::chrono_literals;

constexpr const char *kMangoHud = "VK_LAYER_MANGOHUD_overlay";
constexpr const char *kMesaOverlay = "VK_LAYER_MESA_overlay";
constexpr const char *kSystemLayers = "/usr/share/vulkan/explicit_layer.d";
constexpr const char *kOverlayAboveLine = "is above splitvk in the layer chain";

// atrium at the size the split tests compare; the overlays draw their HUD in the top-left corner,
// which at this size stays clear of both foveae.
constexpr uint32_t kWidth = 2400;
constexpr uint32_t kHeight = 1080;
constexpr int kFrames = 4;

// The overlays' own validation message: MangoHud and the Mesa overlay (which share their drawing
// code) begin their HUD render pass with loadOp LOAD after a layout transition whose barrier does
// not make the transition visible to the attachment read. Every test proves the message is the
// overlay's with a control run of the overlay and validation alone, without splitvk.
constexpr const char *kOverlayHazard[] = {"SYNC-HAZARD-READ-AFTER-WRITE", "vkCmdBeginRenderPass",
                                          "loadOp VK_ATTACHMENT_LOAD_OP_LOAD",
                                          "prior_usage: SYNC_IMAGE_LAYOUT_TRANSITION"};

bool overlay_hazard(const std::string &message) {
    return std::all_of(std::begin(kOverlayHazard), std::end(kOverlayHazard),
                       [&](const char *part) { return message.find(part) != std::string::npos; });
}

// The messages of a validation log (a message starts at a line that is not indented) that are
// not the overlay's own.
std::vector<std::string> foreign_messages(const std::vector<std::string> &messages) {
    std::vector<std::string> foreign;
    for (const auto &m : messages)
        if (!overlay_hazard(m)) foreign.push_back(m);
    return foreign;
}

std::vector<std::string> log_messages(const std::filesystem::path &log) {
    std::vector<std::string> messages;
    for (const auto &line : split_lines(read_file(log)))
        if (!line.empty() && line[0] != ' ' && line[0] != '\t') messages.push_back(line);
    return messages;
}

class OtherLayers : public XTest {
protected:
    void SetUp() override {
        XTest::SetUp();
        ASSERT_TRUE(built(explicit_layer_dir()));
        ASSERT_TRUE(built(atrium_path()));
        ASSERT_TRUE(built(agent_path()));
        ASSERT_TRUE(std::filesystem::exists(std::string(kSystemLayers) + "/VkLayer_MESA_overlay.json"))
            << "the Mesa overlay layer is not installed (mesa-vulkan-drivers)";
        ASSERT_TRUE(std::filesystem::exists("/usr/share/vulkan/implicit_layer.d/MangoHud.json"))
            << "MangoHud is not installed (mangohud)";
    }

    // The recipe's own folder for one system layer: a copy of its manifest alone in a folder, so
    // that its place in VK_LAYER_PATH is its place in the chain.
    std::string own_folder(const std::string &manifest) {
        const auto dir = out_ / "layers" / std::filesystem::path(manifest).stem();
        std::filesystem::create_directories(dir);
        std::filesystem::copy_file(std::string(kSystemLayers) + "/" + manifest, dir / manifest,
                                   std::filesystem::copy_options::overwrite_existing);
        return dir.string();
    }

    // Validation below splitvk, logging to this test's folder; MangoHud and the overlay configured
    // to draw in the top-left corner and to read no user configuration.
    Env base_env() {
        Env e = env();
        enable_loader_debug(e);
        e["SPLITVK_LOG_LEVEL"] = "info";
        e["SPLITVK_TILE_WAIT"] = "60000"; // lockstep: a slow machine must not turn into a mismatch
        e["MANGOHUD_CONFIG"] = "position=top-left";
        e["VK_LAYER_MESA_OVERLAY_CONFIG"] = "position=top-left";
        return e;
    }

    // The four orders, top first; `expected` is what the loader must report.
    Env mangohud_above(std::vector<std::string> *expected) {
        Env e = base_env();
        e["MANGOHUD"] = "1";
        e["VK_LAYER_PATH"] =
            explicit_layer_dir().string() + ":" + own_folder("VkLayer_khronos_validation.json");
        e["VK_INSTANCE_LAYERS"] = std::string(kLayerName) + ":" + kValidationLayerName;
        *expected = {kMangoHud, kLayerName, kValidationLayerName};
        return e;
    }
    Env mangohud_below(std::vector<std::string> *expected) {
        Env e = base_env();
        e["MANGOHUD"] = "1";
        make_implicit_layer_visible(e); // the build tree's implicit folder before /usr/share's
        e["SPLITVK_ENABLE"] = "1";
        e["VK_INSTANCE_LAYERS"] = kValidationLayerName;
        *expected = {kLayerName, kMangoHud, kValidationLayerName};
        return e;
    }
    Env mesa_overlay_above(std::vector<std::string> *expected) {
        Env e = base_env();
        e["VK_LAYER_PATH"] = own_folder("VkLayer_MESA_overlay.json") + ":" + explicit_layer_dir().string() +
                             ":" + own_folder("VkLayer_khronos_validation.json");
        // The variable's order is deliberately not the chain's: with this loader it does not count.
        e["VK_INSTANCE_LAYERS"] = std::string(kValidationLayerName) + ":" + kLayerName + ":" + kMesaOverlay;
        *expected = {kMesaOverlay, kLayerName, kValidationLayerName};
        return e;
    }
    Env mesa_overlay_below(std::vector<std::string> *expected) {
        Env e = base_env();
        e["VK_LAYER_PATH"] = explicit_layer_dir().string() + ":" + own_folder("VkLayer_MESA_overlay.json") +
                             ":" + own_folder("VkLayer_khronos_validation.json");
        e["VK_INSTANCE_LAYERS"] = std::string(kMesaOverlay) + ":" + kValidationLayerName + ":" + kLayerName;
        *expected = {kLayerName, kMesaOverlay, kValidationLayerName};
        return e;
    }

    // The loader's instance call stack holds `expected` in that relative order (other implicit
    // layers, such as Mesa's device_select, may sit anywhere).
    void expect_order(const ProcessResult &r, const std::vector<std::string> &expected) {
        const auto stack = instance_layer_stack(r.err());
        std::string seen;
        for (const auto &s : stack)
            seen += " " + s.name;
        int previous = -1;
        for (const auto &name : expected) {
            const int i = stack_index(stack, name);
            ASSERT_GE(i, 0) << name << " is not in the loader's call stack:" << seen;
            EXPECT_GT(i, previous) << name << " is not below the layers before it in" << seen;
            previous = i;
        }
    }

    // Exit 0, no splitvk error, the layer active, the overlay line exactly when an overlay is above.
    void expect_clean_run(const ProcessResult &r, const std::string &app, bool overlay_above) {
        const std::string err = r.err();
        EXPECT_TRUE(r.ok()) << r.describe() << "\n" << tail(err, 30);
        EXPECT_TRUE(layer_reported_active(err, app)) << tail(err, 30);
        EXPECT_TRUE(grep(err, "[splitvk] error:").empty()) << joined(grep(err, "[splitvk] error:"));
        EXPECT_TRUE(grep(err, "running unsplit").empty()) << tail(err, 30);
        EXPECT_FALSE(grep(err, "split: passes into").empty()) << "nothing was split\n" << tail(err, 30);
        EXPECT_EQ(grep(err, kOverlayAboveLine).size(), overlay_above ? 1u : 0u)
            << joined(grep(err, "[splitvk]"));
    }

    // The client's validation log holds nothing but the overlay's own message.
    void expect_validation_clean(const std::filesystem::path &log) {
        ASSERT_TRUE(std::filesystem::exists(log)) << "validation was not loaded";
        EXPECT_TRUE(foreign_messages(log_messages(log)).empty())
            << "client-side validation reported:" << joined(foreign_messages(log_messages(log)));
    }

    // The agent's session (--validate) closed, and reported nothing but the overlay's own message
    // (which it sees when the overlay is above splitvk: the overlay's passes are forwarded).
    void expect_agent_clean(const Agent &agent) {
        auto deadline = std::chrono::steady_clock::now() + 20s;
        while (grep(agent.log(), "closed after").empty() && std::chrono::steady_clock::now() < deadline)
            std::this_thread::sleep_for(50ms);
        const std::string log = agent.log();
        ASSERT_FALSE(grep(log, "closed after").empty()) << tail(log, 20);
        EXPECT_TRUE(foreign_messages(grep(log, "validation: ")).empty())
            << "the agent's validation reported:" << joined(foreign_messages(grep(log, "validation: ")));
        // Every error is a validation message (its warnings are logged as warnings, not errors).
        const auto errors = grep(log, "] error:");
        EXPECT_TRUE(std::all_of(errors.begin(), errors.end(), [](const std::string &l) {
            return l.find("validation: ") != std::string::npos;
        })) << tail(log, 20);
    }

    // The overlay's message is its own: the overlay with validation, without splitvk, gives it too.
    void expect_overlay_hazard_without_splitvk(Env e) {
        e["VK_INSTANCE_LAYERS"] = kValidationLayerName;
        e.erase("VK_LAYER_PATH");
        e.erase("SPLITVK_ENABLE");
        e.erase("SPLITVK_SERVER");
        if (e.count("MANGOHUD") == 0) {
            e["VK_INSTANCE_LAYERS"] = std::string(kMesaOverlay) + ":" + kValidationLayerName;
            e["VK_LAYER_PATH"] =
                own_folder("VkLayer_MESA_overlay.json") + ":" + own_folder("VkLayer_khronos_validation.json");
        }
        const auto log = configure_validation(e, out_ / "control-validation");
        auto r =
            run_app({"vkcube", "--c", "10", "--width", "256", "--height", "256"}, e, out_, "control", 120s);
        ASSERT_TRUE(r.ok()) << r.describe();
        EXPECT_FALSE(layer_reported_active(r.err(), "vkcube")) << "splitvk was loaded in the control run";
        const auto messages = log_messages(log);
        EXPECT_TRUE(std::any_of(messages.begin(), messages.end(), overlay_hazard))
            << "the overlay alone does not give the message this test excuses";
        EXPECT_TRUE(foreign_messages(messages).empty()) << joined(foreign_messages(messages));
    }

    std::vector<std::string> atrium_argv() const {
        return {atrium_path().string(),
                "--width",
                std::to_string(kWidth),
                "--height",
                std::to_string(kHeight),
                "--eyes",
                "2",
                "--frames",
                std::to_string(kFrames),
                "--hold"};
    }

    // atrium held on its last frame, grabbed from the X server, then ended with SIGTERM.
    ProcessResult run_atrium(const Env &e, const std::string &name, Image *grab) {
        ProcessSpec spec;
        spec.argv = atrium_argv();
        spec.env = e;
        spec.out_dir = out_;
        spec.name = name;
        Process p(spec);
        if (!p.start()) {
            ADD_FAILURE() << p.error();
            return {};
        }
        const std::string holding = "holding frame " + std::to_string(kFrames - 1);
        if (!p.wait_for_line(holding, 240s)) {
            auto r = p.terminate(5s);
            ADD_FAILURE() << name << " never printed '" << holding << "': " << r.describe() << "\n"
                          << tail(r.err(), 30);
            return r;
        }
        std::string error;
        const bool grabbed =
            grab_stable(display(), 0, 0, kWidth, kHeight, out_ / (name + ".raw"), grab, &error);
        auto r = p.terminate(10s);
        EXPECT_TRUE(grabbed) << error;
        return r;
    }

    // One order: vkcube and atrium split with the agent; foveae exact when splitvk is on top.
    void run_order(const Env &e, const std::vector<std::string> &expected) {
        const bool splitvk_on_top = expected.front() == kLayerName;
        {
            SCOPED_TRACE("control: the overlay without splitvk");
            ASSERT_NO_FATAL_FAILURE(expect_overlay_hazard_without_splitvk(e));
        }
        Image native;
        if (splitvk_on_top) {
            auto r = run_atrium(env(), "native", &native);
            ASSERT_TRUE(r.ok()) << r.describe();
            ASSERT_GT(distinct_colours(native), 1000u) << "the native grab looks blank";
        }
        {
            SCOPED_TRACE("vkcube");
            Agent agent;
            ASSERT_TRUE(agent.start(env(), out_, {"--validate"}, 0, "agent-vkcube")) << agent.error();
            Env cube = e;
            cube["SPLITVK_SERVER"] = agent.address();
            const auto validation_log = configure_validation(cube, out_ / "vkcube-validation");
            auto r = run_app({"vkcube", "--c", "30", "--width", "256", "--height", "256"}, cube, out_,
                             "vkcube", 180s);
            ASSERT_NO_FATAL_FAILURE(expect_order(r, expected));
            expect_clean_run(r, "vkcube", !splitvk_on_top);
            expect_agent_clean(agent);
            expect_validation_clean(validation_log);
        }
        {
            SCOPED_TRACE("splitvk-atrium");
            Agent agent;
            ASSERT_TRUE(agent.start(env(), out_, {"--validate"}, 0, "agent-atrium")) << agent.error();
            Env split = e;
            split["SPLITVK_SERVER"] = agent.address();
            const auto validation_log = configure_validation(split, out_ / "atrium-validation");
            Image grab;
            auto r = run_atrium(split, "split", &grab);
            ASSERT_NO_FATAL_FAILURE(expect_order(r, expected));
            expect_clean_run(r, "splitvk-atrium", !splitvk_on_top);
            expect_agent_clean(agent);
            expect_validation_clean(validation_log);
            if (splitvk_on_top) {
                for (const Rect &f : default_foveae(kWidth, kHeight, 2)) {
                    const auto cmp = compare_exact(native, grab, f.x, f.y, f.w, f.h);
                    EXPECT_TRUE(cmp.equal()) << "fovea (" << f.x << "," << f.y << " " << f.w << "x" << f.h
                                             << ") differs from native: " << cmp.summary() << "\n"
                                             << save_mismatch_artefacts(out_, "fovea", native, grab);
                }
            }
        }
    }
};

TEST_F(OtherLayers, MangoHudAboveSplitvk) {
    std::vector<std::string> expected;
    const Env e = mangohud_above(&expected);
    run_order(e, expected);
}

TEST_F(OtherLayers, MangoHudBelowSplitvk) {
    std::vector<std::string> expected;
    const Env e = mangohud_below(&expected);
    run_order(e, expected);
}

TEST_F(OtherLayers, MesaOverlayAboveSplitvk) {
    std::vector<std::string> expected;
    const Env e = mesa_overlay_above(&expected);
    run_order(e, expected);
}

TEST_F(OtherLayers, MesaOverlayBelowSplitvk) {
    std::vector<std::string> expected;
    const Env e = mesa_overlay_below(&expected);
    run_order(e, expected);
}

// The recipe for validation alone, headless (the probe), both ways round: the folders' order in
// VK_LAYER_PATH decides, whatever the order in VK_INSTANCE_LAYERS; and an implicitly enabled
// splitvk is above every explicit layer.
class LayerOrder : public XTest {
protected:
    std::vector<StackEntry> probe_stack(Env e) {
        enable_loader_debug(e);
        auto r = run_app({probe_path().string()}, e, out_, "probe-" + std::to_string(runs_++), 60s);
        EXPECT_TRUE(r.ok()) << r.describe();
        return instance_layer_stack(r.err());
    }
    std::string validation_folder() {
        const auto dir = out_ / "layers" / "validation";
        std::filesystem::create_directories(dir);
        std::filesystem::copy_file(std::string(kSystemLayers) + "/VkLayer_khronos_validation.json",
                                   dir / "VkLayer_khronos_validation.json",
                                   std::filesystem::copy_options::overwrite_existing);
        return dir.string();
    }
    int runs_ = 0;
};

TEST_F(LayerOrder, LayerPathFolderOrderDecides) {
    const std::string ours = explicit_layer_dir().string();
    const std::string validation = validation_folder();
    for (const char *instance_layers : {"VK_LAYER_SPLITVK_split_render:VK_LAYER_KHRONOS_validation",
                                        "VK_LAYER_KHRONOS_validation:VK_LAYER_SPLITVK_split_render"}) {
        SCOPED_TRACE(instance_layers);
        Env e = env();
        e["VK_INSTANCE_LAYERS"] = instance_layers;
        e["VK_LAYER_PATH"] = ours + ":" + validation;
        auto stack = probe_stack(e);
        EXPECT_LT(stack_index(stack, kLayerName), stack_index(stack, kValidationLayerName));
        EXPECT_GE(stack_index(stack, kLayerName), 0);
        e["VK_LAYER_PATH"] = validation + ":" + ours;
        stack = probe_stack(e);
        EXPECT_GT(stack_index(stack, kLayerName), stack_index(stack, kValidationLayerName));
        EXPECT_GE(stack_index(stack, kValidationLayerName), 0);
    }
}

// VK_ADD_LAYER_PATH is searched before the system folders, so a splitvk found through it is above
// validation from /usr/share whatever the order in VK_INSTANCE_LAYERS (why the older recipe worked).
TEST_F(LayerOrder, AddLayerPathIsSearchedFirst) {
    for (const char *instance_layers : {"VK_LAYER_SPLITVK_split_render:VK_LAYER_KHRONOS_validation",
                                        "VK_LAYER_KHRONOS_validation:VK_LAYER_SPLITVK_split_render"}) {
        SCOPED_TRACE(instance_layers);
        Env e = env();
        e["VK_INSTANCE_LAYERS"] = instance_layers;
        e["VK_ADD_LAYER_PATH"] = explicit_layer_dir().string();
        const auto stack = probe_stack(e);
        EXPECT_GE(stack_index(stack, kLayerName), 0);
        EXPECT_LT(stack_index(stack, kLayerName), stack_index(stack, kValidationLayerName));
    }
}

TEST_F(LayerOrder, ImplicitSplitvkIsAboveExplicitLayers) {
    Env e = env();
    make_implicit_layer_visible(e);
    e["SPLITVK_ENABLE"] = "1";
    e["VK_INSTANCE_LAYERS"] = kValidationLayerName;
    const auto stack = probe_stack(e);
    EXPECT_GE(stack_index(stack, kLayerName), 0);
    EXPECT_LT(stack_index(stack, kLayerName), stack_index(stack, kValidationLayerName));
}

} // namespace
} // namespace splitvk::e2e
