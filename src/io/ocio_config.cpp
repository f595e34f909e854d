#include "io/ocio_config.h"

#include <OpenColorIO/OpenColorIO.h>
#include <unistd.h>

#include <algorithm>
#include <climits>
#include <sstream>
#include <utility>

#include "base/bounded_read.h"
#include "base/error.h"
#include "base/fnv1a.h"
#include "base/memo.h"
#include "io/paths.h"

namespace OCIO = OCIO_NAMESPACE;

namespace spectex {

namespace {

// The folder a config's relative search paths are resolved from, as CreateFromFile sets it: the
// absolute folder of the config file.
std::string config_dir(const std::string& path) {
    std::string abs = path;
    if (abs.empty() || abs[0] != '/') {
        char cwd[PATH_MAX];
        if (::getcwd(cwd, sizeof cwd)) abs = std::string(cwd) + "/" + path;
    }
    return folder_of(abs);
}

// Every FileTransform anywhere in `t` (groups included).
void collect_file_transforms(const OCIO::ConstTransformRcPtr& t, std::vector<std::string>& out,
                             int depth = 0) {
    if (!t || depth > 64) return;
    if (auto f = OCIO::DynamicPtrCast<const OCIO::FileTransform>(t)) {
        if (f->getSrc() && *f->getSrc()) out.emplace_back(f->getSrc());
    } else if (auto g = OCIO::DynamicPtrCast<const OCIO::GroupTransform>(t)) {
        for (int i = 0; i < g->getNumTransforms(); ++i)
            collect_file_transforms(g->getTransform(i), out, depth + 1);
    }
}

// The LUT files a config references (FileTransform src in its colour spaces, looks, view and named
// transforms), resolved through the config's context as the processor would: each must be a
// regular file of bounded size, checked before OCIO reads it (a LUT on /dev/zero, /dev/urandom or
// a FIFO would otherwise hang the processor build). A reference that does not resolve is left to
// OCIO, which reports it when (and only when) a transform uses it.
// The resolved paths of the LUT files a config references (those that resolve).
std::vector<std::pair<std::string, std::string>> lut_files(const OCIO::ConstConfigRcPtr& cfg) {
    std::vector<std::string> srcs;
    const int n = cfg->getNumColorSpaces(OCIO::SEARCH_REFERENCE_SPACE_ALL, OCIO::COLORSPACE_ALL);
    for (int i = 0; i < n; ++i) {
        auto cs = cfg->getColorSpace(cfg->getColorSpaceNameByIndex(OCIO::SEARCH_REFERENCE_SPACE_ALL,
                                                                   OCIO::COLORSPACE_ALL, i));
        if (!cs) continue;
        collect_file_transforms(cs->getTransform(OCIO::COLORSPACE_DIR_TO_REFERENCE), srcs);
        collect_file_transforms(cs->getTransform(OCIO::COLORSPACE_DIR_FROM_REFERENCE), srcs);
    }
    for (int i = 0; i < cfg->getNumLooks(); ++i) {
        auto look = cfg->getLook(cfg->getLookNameByIndex(i));
        if (!look) continue;
        collect_file_transforms(look->getTransform(), srcs);
        collect_file_transforms(look->getInverseTransform(), srcs);
    }
    for (int i = 0; i < cfg->getNumViewTransforms(); ++i) {
        auto vt = cfg->getViewTransform(cfg->getViewTransformNameByIndex(i));
        if (!vt) continue;
        collect_file_transforms(vt->getTransform(OCIO::VIEWTRANSFORM_DIR_TO_REFERENCE), srcs);
        collect_file_transforms(vt->getTransform(OCIO::VIEWTRANSFORM_DIR_FROM_REFERENCE), srcs);
    }
    for (int i = 0; i < cfg->getNumNamedTransforms(OCIO::NAMEDTRANSFORM_ALL); ++i) {
        auto nt =
            cfg->getNamedTransform(cfg->getNamedTransformNameByIndex(OCIO::NAMEDTRANSFORM_ALL, i));
        if (!nt) continue;
        collect_file_transforms(nt->getTransform(OCIO::TRANSFORM_DIR_FORWARD), srcs);
        collect_file_transforms(nt->getTransform(OCIO::TRANSFORM_DIR_INVERSE), srcs);
    }
    std::sort(srcs.begin(), srcs.end());
    srcs.erase(std::unique(srcs.begin(), srcs.end()), srcs.end());
    OCIO::ConstContextRcPtr ctx = cfg->getCurrentContext();
    std::vector<std::pair<std::string, std::string>> out;  // (src as written, resolved path)
    for (const auto& src : srcs) {
        try {
            out.emplace_back(src, ctx->resolveFileLocation(src.c_str()));
        } catch (const OCIO::Exception&) {
            // missing: OCIO's own error, if a transform in use needs it
        }
    }
    return out;
}

void check_lut_files(const OCIO::ConstConfigRcPtr& cfg, const std::string& config_path) {
    for (const auto& [src, resolved] : lut_files(cfg))
        check_regular_file(resolved, file_limits::kLutFile,
                           "a LUT file (FileTransform '" + src + "' in " + config_path + ")");
}

// A config's bytes, read as every file spectex reads (a regular file of bounded size). OpenColorIO
// 2.2 added configs built into the library, named ocio://default, ocio://cg-config-latest, ...;
// 2.1 has none, and such a name taken for a path failed as "No such file or directory".
std::string read_config_bytes(const std::string& path) {
    if (path.rfind("ocio://", 0) == 0)
        throw Error(
            path + ": " +
            (OCIO::GetVersionHex() < 0x02020000
                 ? "this OpenColorIO (" + std::string(OCIO::GetVersion()) +
                       ") has no built-in configs (ocio:// names came with 2.2)"
                 : std::string("spectex reads OCIO configs from files, not built-in ones")) +
            "; use a config file (--config FILE or $OCIO), or neither for the config spectex "
            "ships, the default");
    return read_file_bounded(path, file_limits::kOcioConfig, "an OCIO config");
}

// An OCIO config read from checked bytes (a regular file of bounded size, never a device or a
// FIFO), with the working folder CreateFromFile would give it, and its LUT files checked too.
OCIO::ConstConfigRcPtr parse_ocio_config(const std::string& path, const std::string& bytes) {
    std::istringstream text(bytes);
    OCIO::ConstConfigRcPtr cfg;
    try {
        OCIO::ConfigRcPtr editable = OCIO::Config::CreateFromStream(text)->createEditableCopy();
        editable->setWorkingDir(config_dir(path).c_str());
        cfg = editable;
    } catch (const OCIO::Exception& e) {
        std::string why = e.what();
        for (char& c : why)
            if (c == '\n' || c == '\r') c = ' ';
        throw Error(path + ": cannot load OCIO config: " + why);
    }
    try {
        check_lut_files(cfg, path);
    } catch (const OCIO::Exception& e) {
        throw Error(path + ": cannot list the config's LUT files: " + e.what());
    }
    return cfg;
}

}  // namespace

// A config is parsed once per process for the same path and the same bytes: a batch of many small
// files parsed the YAML again for every file (1.4 ms of a tiny file's 5.4 ms of CPU). The file is
// still read every time, so a config edited during a batch is parsed anew. OCIO's configs are
// immutable once made (Const) and safe to share between threads; reusing one also reuses its own
// cache of processors.
OCIO::ConstConfigRcPtr load_ocio_config(const std::string& path) {
    std::string bytes = read_config_bytes(path);
    // A batch uses one or two configs: at most 8 are kept.
    static Memo<std::pair<std::string, std::string>, OCIO::ConstConfigRcPtr> parsed(8);
    auto key = std::make_pair(path, std::move(bytes));
    return parsed.get(key, [&] { return parse_ocio_config(path, key.second); });
}

std::vector<std::string> ocio_config_files(const std::string& config_path) {
    std::vector<std::string> files = {config_path};
    OCIO::ConstConfigRcPtr cfg = load_ocio_config(config_path);
    for (const auto& f : lut_files(cfg)) files.push_back(f.second);
    return files;
}

std::string ocio_config_path(const std::string& data_dir, const std::string& config_override) {
    if (!config_override.empty()) return config_override;
    if (const char* env = std::getenv("OCIO"); env && *env) return env;
    return data_dir + "/spectex.ocio";
}

std::string config_checksum(const std::string& config_path) {
    const std::string bytes = read_config_bytes(config_path);
    Fnv1a64 h;
    h.add(bytes.data(), bytes.size());
    const unsigned char separator = 0xff;  // as the settings hash adds each of its texts
    h.add(&separator, 1);
    return h.text();
}

}  // namespace spectex
