#pragma once
// A scratch folder under /tmp for a unit test, removed with everything in it when the test ends.
#include <stdlib.h>

#include <cstdlib>
#include <string>

namespace spectex_test {

struct TempDir {
    TempDir() {
        char t[] = "/tmp/spectex-unit-XXXXXX";
        path = mkdtemp(t);
    }
    ~TempDir() { std::system(("rm -rf '" + path + "'").c_str()); }
    TempDir(const TempDir&) = delete;
    TempDir& operator=(const TempDir&) = delete;
    std::string operator/(const std::string& n) const { return path + "/" + n; }
    std::string path;
};

}  // namespace spectex_test
