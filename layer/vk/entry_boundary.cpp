// The entry points' exception boundary (entry_boundary.h).

#include "vk/entry_boundary.h"

#include "capture/session.h"
#include "core/device.h"
#include "log.h"

#include <cstdio>
#include <cstdlib>
#include <new>
#include <string>
#include <typeinfo>

#include <cxxabi.h>
#include <unistd.h>

namespace splitvk {
namespace {

// What the current exception is, into `out`: its type and what(). The type is demangled where
// that can allocate, and left mangled where not: the exception may be a bad_alloc.
void describe_current_exception(char *out, size_t size, bool *bad_alloc) {
    *bad_alloc = false;
    const std::type_info *type = abi::__cxa_current_exception_type();
    const char *mangled = type ? type->name() : nullptr;
    int status = -1;
    char *demangled = mangled ? abi::__cxa_demangle(mangled, nullptr, nullptr, &status) : nullptr;
    const char *type_name = status == 0 && demangled ? demangled : mangled ? mangled : "an unknown type";
    try {
        throw;
    } catch (const std::bad_alloc &e) {
        *bad_alloc = true;
        std::snprintf(out, size, "%s (%s)", type_name, e.what());
    } catch (const std::exception &e) {
        std::snprintf(out, size, "%s (%s)", type_name, e.what());
    } catch (...) {
        std::snprintf(out, size, "%s, not a std::exception", type_name);
    }
    std::free(demangled);
}

const char *answer(EntryReturns returns, bool bad_alloc) {
    switch (returns) {
    case EntryReturns::Nothing:
        return "the call returns no result";
    case EntryReturns::VkResult:
        return bad_alloc ? "the call returns VK_ERROR_OUT_OF_HOST_MEMORY"
                         : "the call returns VK_ERROR_UNKNOWN";
    case EntryReturns::XrResult:
        return bad_alloc ? "the call returns XR_ERROR_OUT_OF_MEMORY"
                         : "the call returns XR_ERROR_RUNTIME_FAILURE";
    case EntryReturns::Value:
        break;
    }
    return "the call returns 0 (NULL, VK_FALSE)";
}

// TEST_SPLITVK_THROW, parsed at the first call of an armed boundary.
struct TestThrow {
    TestThrow() {
        const char *value = std::getenv("TEST_SPLITVK_THROW");
        const std::string text = value ? value : "";
        const auto colon = text.find(':');
        name = text.substr(0, colon);
        if (colon != std::string::npos) call = std::strtoull(text.c_str() + colon + 1, nullptr, 10);
    }
    std::string name;
    unsigned long long call = 0;
    std::atomic<unsigned long long> seen{0};
};

} // namespace

std::atomic<bool> g_test_throw_armed{std::getenv("TEST_SPLITVK_THROW") != nullptr};

bool test_throw_due(const char *name) noexcept {
    static TestThrow t;
    if (t.name != name) return false;
    return t.seen.fetch_add(1) >= t.call;
}

bool entry_threw(const char *name, DeviceState *device, EntryReturns returns, bool creates,
                 std::atomic<bool> &said) noexcept {
    char what[512];
    bool bad_alloc = false;
    describe_current_exception(what, sizeof(what), &bad_alloc);
    Session *session = device ? device->session.get() : nullptr;
    try {
        const bool ended = session && session->abandon();
        if (said.exchange(true)) return bad_alloc;
        SPLITVK_ERROR(
            "%s: %s thrown inside splitvk; %s%s%s%s", name, what, answer(returns, bad_alloc),
            creates ? " (what was made for it below splitvk, if anything, is not destroyed: it stays "
                      "alive until its parent is)"
                    : "",
            ended ? "; splitvk stops splitting this device: " : "", ended ? session->fallback() : "");
    } catch (...) {
        // The line itself could not be allocated: a fixed one, written as it is.
        static const char kLine[] =
            "[splitvk] error: an exception inside splitvk, and no memory to say more\n";
        [[maybe_unused]] const ssize_t written = ::write(STDERR_FILENO, kLine, sizeof(kLine) - 1);
    }
    return bad_alloc;
}

} // namespace splitvk
