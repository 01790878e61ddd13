// splitvk-agent: the server side of splitvk.

#include "agent_options.h"
#include "devices.h"
#include "identity.h"
#include "listener.h"
#include "log.h"
#include "vk_codec.h"

#include <vulkan/vulkan.h>

#include <algorithm>
#include <cstdio>
#include <ctime>
#include <fstream>
#include <iterator>
#include <optional>

#include <unistd.h>

namespace {

int list_devices() {
    std::string error;
    const auto gpus = splitvk::agent::enumerate_gpus(&error);
    if (gpus.empty()) {
        SPLITVK_ERROR("%s", error.c_str());
        return 1;
    }
    for (const auto &gpu : gpus) {
        std::printf("%u: %s (%s, Vulkan %u.%u.%u, %s, UUID %s)\n", gpu.index, gpu.name.c_str(),
                    gpu.type.c_str(), VK_API_VERSION_MAJOR(gpu.api_version),
                    VK_API_VERSION_MINOR(gpu.api_version), VK_API_VERSION_PATCH(gpu.api_version),
                    gpu.driver.c_str(), gpu.uuid.c_str());
    }
    return 0;
}

} // namespace

int main(int argc, char **argv) {
    splitvk::set_log_prefix("[splitvk-agent]");
    splitvk::set_log_level(splitvk::LogLevel::Info);

    const auto parsed = splitvk::agent::parse_agent_options({argv + 1, argv + argc});
    if (!parsed.error.empty()) {
        SPLITVK_ERROR("%s", parsed.error.c_str());
        return 2;
    }
    auto options = parsed.options;
    if (options.help) {
        std::fputs(splitvk::agent::agent_usage(), stdout);
        return 0;
    }
    if (options.list_devices) return list_devices();

    // --print-fingerprint needs nothing but the identity (made now if there is none).
    if (options.print_fingerprint) {
        auto identity = splitvk::agent::load_agent_identity(options);
        if (!identity) {
            SPLITVK_ERROR("%s", identity.error().c_str());
            return 2;
        }
        std::printf("%s\n", identity->certificate.fingerprint.c_str());
        return 0;
    }

    // The operator's profile first: a bad one is one line before any GPU is touched.
    std::optional<splitvk::protocol::DeviceProfile> profile;
    if (!options.emulate_limits.empty()) {
        std::ifstream in(options.emulate_limits, std::ios::binary);
        if (!in.is_open()) {
            SPLITVK_ERROR("--emulate-limits %s: cannot read it", options.emulate_limits.c_str());
            return 2;
        }
        const std::string text((std::istreambuf_iterator<char>(in)), std::istreambuf_iterator<char>());
        auto parsed_profile = splitvk::protocol::parse_profile(text, options.emulate_limits);
        if (!parsed_profile) {
            SPLITVK_ERROR("--emulate-limits %s: %s", options.emulate_limits.c_str(),
                          parsed_profile.error().c_str());
            return 2;
        }
        profile = std::move(parsed_profile).value();
    }

    // The TLS identity before any GPU, after the profile (whose error must be the only line): a
    // listener forks its sessions with the identity loaded (a confined session cannot read it).
    auto identity = splitvk::agent::load_agent_identity(options);
    std::shared_ptr<splitvk::protocol::TlsContext> tls;
    if (identity) {
        auto context = splitvk::protocol::TlsContext::server(identity->identity);
        if (context)
            tls = std::move(context).value();
        else
            identity = splitvk::protocol::Error{identity->source + ": " + context.error()};
    }
    const bool loopback = splitvk::agent::is_loopback_host(options.listen_host);
    if (!identity) {
        // A loopback agent can serve plaintext clients without one; any other must speak TLS.
        if (!loopback) {
            SPLITVK_ERROR("TLS identity: %s; an agent on %s needs one", identity.error().c_str(),
                          options.listen_host.c_str());
            return 2;
        }
        SPLITVK_WARN("TLS identity: %s; TLS clients (SPLITVK_TLS=on) will be turned away",
                     identity.error().c_str());
    } else {
        const auto &cert = identity->certificate;
        SPLITVK_INFO(
            "TLS identity %s (%s, %s), valid until %s", cert.fingerprint.c_str(), cert.subject.c_str(),
            identity->generated ? ("made now in " + identity->source).c_str() : identity->source.c_str(),
            splitvk::protocol::format_utc(cert.not_after).c_str());
        const std::string problem =
            splitvk::protocol::validity_problem(cert, static_cast<int64_t>(std::time(nullptr)));
        if (!problem.empty())
            SPLITVK_WARN("the TLS certificate %s: clients will refuse it (%s)", problem.c_str(),
                         options.tls_cert.empty()
                             ? "remove agent.crt and agent.key from the state directory to "
                               "make a new one; clients then see a changed key"
                             : "renew --tls-cert");
    }

    std::string error;
    const auto gpus = splitvk::agent::enumerate_gpus(&error);
    if (!options.device_uuid.empty()) {
        // A UUID names the same GPU however the loader orders them (a systemd instance per GPU).
        const auto found = std::find_if(gpus.begin(), gpus.end(),
                                        [&](const auto &gpu) { return gpu.uuid == options.device_uuid; });
        if (found == gpus.end()) {
            SPLITVK_ERROR("--device %s: %s", options.device_uuid.c_str(),
                          gpus.empty() ? error.c_str() : "no GPU has this UUID (see --list-devices)");
            return 2;
        }
        options.device_index = found->index;
    }
    if (options.device_index >= gpus.size()) {
        SPLITVK_ERROR("--device %u: %s", options.device_index,
                      gpus.empty() ? error.c_str() : "no such GPU (see --list-devices)");
        return 2;
    }
    const auto &gpu = gpus[options.device_index];
    splitvk::protocol::DeviceDescription device = gpu.description;
    if (profile) {
        splitvk::protocol::apply(device, *profile);
        std::string changed;
        for (const auto &c : splitvk::protocol::limit_changes(gpu.description, device))
            changed += (changed.empty() ? "" : ", ") + c.name + " " + c.from + " -> " + c.to;
        const auto hidden = splitvk::protocol::features_hidden(gpu.description, device);
        SPLITVK_INFO("--emulate-limits %s: behaving as a GPU with %s; %zu features hidden",
                     options.emulate_limits.c_str(), changed.empty() ? "the same limits" : changed.c_str(),
                     hidden.size());
    }
    std::optional<splitvk::agent::Advertisement> advertisement;
    if (options.advertise) {
        splitvk::protocol::AgentRecord record;
        record.session = splitvk::protocol::session_text(splitvk::codec::kCodecFingerprint);
        if (identity) record.certificate = identity->certificate.fingerprint;
        record.tls = tls != nullptr;
        record.gpu_name = gpu.name;
        record.gpu_uuid = gpu.uuid;
        char host[256] = {};
        if (gethostname(host, sizeof(host) - 1) != 0) std::snprintf(host, sizeof(host), "splitvk-agent");
        std::string name = options.advertise_name.empty()
                               ? splitvk::agent::default_advertised_name(host, options.device_index, gpu.name)
                               : options.advertise_name;
        advertisement = splitvk::agent::Advertisement{std::move(name), std::move(record)};
        if (loopback)
            SPLITVK_WARN("--advertise: listening on %s, a loopback address: other machines find this agent "
                         "but cannot reach it (--listen 0.0.0.0:PORT with --token-file serves them)",
                         options.listen_host.c_str());
    }
    return splitvk::agent::run_listener(options, gpu.name, device, std::move(tls), advertisement);
}
