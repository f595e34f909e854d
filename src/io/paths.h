#pragma once
// Path strings, one copy of each rule. Plain string rules (not std::filesystem::path, whose
// parent_path() of "a.png" is "" and of "a//b" keeps a separator): the folder and name printed in
// messages and used for temporary files are exactly the ones a user typed.
#include <string>

namespace spectex {

// The folder of a file's path, as dirname(1) gives it: "." for a bare name, "/" at the root.
std::string folder_of(const std::string& path);
// What follows the last '/', the whole path when there is none.
std::string file_name_of(const std::string& path);
// The folder of the running executable (/proc/self/exe), "" when it cannot be read.
std::string executable_dir();

}  // namespace spectex
