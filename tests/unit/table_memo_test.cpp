// The tables by name (pipeline/table_memo): read once per process, so a verify of many files that
// record the same observer and lights reads each once; a name that cannot be read fails alike
// for every caller.
#include "pipeline/table_memo.h"

#include <gtest/gtest.h>

#include <cstdio>
#include <fstream>
#include <string>

#include "base/error.h"
#include "temp_dir.h"

namespace spectex {
namespace {

const std::string kData = SPECTEX_TEST_DATA_DIR;

TEST(TableMemo, AnIlluminantFileIsReadOnceAndSharedByLaterCallers) {
    spectex_test::TempDir d;
    const std::string light = d / "light.csv";
    {
        std::ofstream f(light);
        f << "wavelength,value\n";
        for (int l = 300; l <= 830; l += 5) f << l << "," << 100 + (l % 7) << "\n";
    }
    const auto first = illuminant_table(kData, light);
    ASSERT_NE(first, nullptr);
    // Gone from disk: a second caller gets the same table, not a read error.
    ASSERT_EQ(std::remove(light.c_str()), 0);
    const auto second = illuminant_table(kData, light);
    EXPECT_EQ(first.get(), second.get());
    EXPECT_EQ(second->value, first->value);
    // Another name is another table.
    EXPECT_NE(illuminant_table(kData, "D65").get(), first.get());
}

TEST(TableMemo, TheObserverIsTheLoadedOneAndShared) {
    const auto a = observer_table(kData, "cie1931-2"), b = observer_table(kData, "cie1931-2");
    EXPECT_EQ(a.get(), b.get());
    const Observer direct = load_observer(kData, "cie1931-2");
    EXPECT_EQ(a->y.lambda, direct.y.lambda);
    EXPECT_EQ(a->y.value, direct.y.value);
}

TEST(TableMemo, AnUnreadableNameFailsForEveryCaller) {
    spectex_test::TempDir d;
    const std::string missing = d / "no_such_light.csv";
    EXPECT_THROW(illuminant_table(kData, missing), Error);
    EXPECT_THROW(illuminant_table(kData, missing), Error);
}

}  // namespace
}  // namespace spectex
