// What the tests that run the parode binary share: a scratch folder per test
// (made before it, removed after it) and reading a file whole.
// Trade-off: the folder is named after the fixture and the process, so test
// programs running side by side (ctest -j) never share one; a test that
// needs a second folder makes it inside the first.
#pragma once
#include <gtest/gtest.h>
#include <unistd.h>

#include <filesystem>
#include <fstream>
#include <sstream>
#include <string>

namespace parode::test {

// The whole of file `p` (empty if it cannot be read).
inline std::string slurp(const std::filesystem::path& p) {
    std::ifstream in(p, std::ios::binary);
    std::ostringstream os;
    os << in.rdbuf();
    return os.str();
}

// A fixture whose tests each get the empty folder dir_.
class ScratchDirTest : public ::testing::Test {
protected:
    explicit ScratchDirTest(std::string name) : name_(std::move(name)) {}
    void SetUp() override {
        dir_ = std::filesystem::temp_directory_path() / ("parode_test_" + name_ + "_" + std::to_string(::getpid()));
        std::filesystem::remove_all(dir_);
        std::filesystem::create_directories(dir_);
    }
    void TearDown() override { std::filesystem::remove_all(dir_); }

    std::filesystem::path dir_;

private:
    std::string name_;
};

}  // namespace parode::test
