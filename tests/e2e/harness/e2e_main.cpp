// main() for every e2e test binary: the shared Xvfb is started by the first test that needs it and
// stopped here when the binary ends, whatever the tests did.
#include "xvfb.h"

#include <gtest/gtest.h>

namespace {

class XvfbEnvironment : public ::testing::Environment {
public:
    void TearDown() override { splitvk::e2e::stop_shared_xvfb(); }
};

} // namespace

int main(int argc, char **argv) {
    ::testing::InitGoogleTest(&argc, argv);
    ::testing::AddGlobalTestEnvironment(new XvfbEnvironment);
    return RUN_ALL_TESTS();
}
