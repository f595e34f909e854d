#include "io/spectral_exr_info.h"

#include <Iex.h>
#include <ImfBoxAttribute.h>
#include <ImfChannelList.h>
#include <ImfChannelListAttribute.h>
#include <ImfChromaticitiesAttribute.h>
#include <ImfCompressionAttribute.h>
#include <ImfDoubleAttribute.h>
#include <ImfFloatAttribute.h>
#include <ImfFloatVectorAttribute.h>
#include <ImfHeader.h>
#include <ImfIntAttribute.h>
#include <ImfLineOrderAttribute.h>
#include <ImfMatrixAttribute.h>
#include <ImfMultiPartInputFile.h>
#include <ImfRationalAttribute.h>
#include <ImfStringAttribute.h>
#include <ImfStringVectorAttribute.h>
#include <ImfTileDescriptionAttribute.h>
#include <ImfVecAttribute.h>
#include <openexr.h>
#include <sys/stat.h>

#include <algorithm>
#include <cerrno>
#include <cstdio>
#include <cstring>
#include <fstream>

#include "base/bounded_read.h"
#include "base/error.h"
#include "io/exr_compression.h"
#include "io/exr_preflight.h"
#include "spectral/wavelength_grid.h"

namespace spectex {

namespace {

std::string type_name(Imf::PixelType t) {
    switch (t) {
        case Imf::HALF:
            return "half";
        case Imf::FLOAT:
            return "float";
        case Imf::UINT:
            return "uint";
        default:
            return "unknown";
    }
}

std::string compression_name(Imf::Compression c) {
    const ExrCompression* known = ExrCompression::find(static_cast<int>(c));
    return known ? known->name : "unknown";
}

std::string attribute_text(const Imf::Attribute& a) {
    char buf[128];
    if (auto s = dynamic_cast<const Imf::StringAttribute*>(&a)) return s->value();
    if (auto f = dynamic_cast<const Imf::FloatAttribute*>(&a)) {
        std::snprintf(buf, sizeof buf, "%g", static_cast<double>(f->value()));
        return buf;
    }
    if (auto i = dynamic_cast<const Imf::IntAttribute*>(&a)) return std::to_string(i->value());
    if (auto v = dynamic_cast<const Imf::StringVectorAttribute*>(&a)) {
        std::string out;
        for (const auto& s : v->value()) out += (out.empty() ? "" : ", ") + s;
        return out;
    }
    if (auto d = dynamic_cast<const Imf::DoubleAttribute*>(&a)) {
        std::snprintf(buf, sizeof buf, "%.17g", d->value());
        return buf;
    }
    if (auto b = dynamic_cast<const Imf::Box2iAttribute*>(&a)) {
        const auto& v = b->value();
        return std::to_string(v.min.x) + "," + std::to_string(v.min.y) + " - " +
               std::to_string(v.max.x) + "," + std::to_string(v.max.y);
    }
    if (auto b = dynamic_cast<const Imf::Box2fAttribute*>(&a)) {
        const auto& v = b->value();
        std::snprintf(buf, sizeof buf, "%g,%g - %g,%g", double(v.min.x), double(v.min.y),
                      double(v.max.x), double(v.max.y));
        return buf;
    }
    if (auto v = dynamic_cast<const Imf::V2iAttribute*>(&a))
        return std::to_string(v->value().x) + "," + std::to_string(v->value().y);
    if (auto v = dynamic_cast<const Imf::V2fAttribute*>(&a)) {
        std::snprintf(buf, sizeof buf, "%g,%g", double(v->value().x), double(v->value().y));
        return buf;
    }
    if (auto v = dynamic_cast<const Imf::V3fAttribute*>(&a)) {
        std::snprintf(buf, sizeof buf, "%g,%g,%g", double(v->value().x), double(v->value().y),
                      double(v->value().z));
        return buf;
    }
    if (auto r = dynamic_cast<const Imf::RationalAttribute*>(&a))
        return std::to_string(r->value().n) + "/" + std::to_string(r->value().d);
    if (auto c = dynamic_cast<const Imf::CompressionAttribute*>(&a))
        return compression_name(c->value());
    if (auto l = dynamic_cast<const Imf::LineOrderAttribute*>(&a)) {
        switch (l->value()) {
            case Imf::INCREASING_Y:
                return "increasing_y";
            case Imf::DECREASING_Y:
                return "decreasing_y";
            case Imf::RANDOM_Y:
                return "random_y";
            default:
                return "unknown";
        }
    }
    if (auto t = dynamic_cast<const Imf::TileDescriptionAttribute*>(&a)) {
        const auto& v = t->value();
        return std::to_string(v.xSize) + "x" + std::to_string(v.ySize) + ", " +
               (v.mode == Imf::ONE_LEVEL       ? "one level"
                : v.mode == Imf::MIPMAP_LEVELS ? "mipmap"
                                               : "ripmap") +
               ", rounding " + (v.roundingMode == Imf::ROUND_UP ? "up" : "down");
    }
    if (auto c = dynamic_cast<const Imf::ChannelListAttribute*>(&a)) {
        std::string out;
        for (auto it = c->value().begin(); it != c->value().end(); ++it) {
            out += (out.empty() ? "" : ", ") + std::string(it.name()) + " " +
                   type_name(it.channel().type);
            if (it.channel().xSampling != 1 || it.channel().ySampling != 1)
                out += " (sampling " + std::to_string(it.channel().xSampling) + "x" +
                       std::to_string(it.channel().ySampling) + ")";
        }
        return out;
    }
    if (auto c = dynamic_cast<const Imf::ChromaticitiesAttribute*>(&a)) {
        const auto& v = c->value();
        std::snprintf(buf, sizeof buf, "red %g,%g green %g,%g blue %g,%g white %g,%g",
                      double(v.red.x), double(v.red.y), double(v.green.x), double(v.green.y),
                      double(v.blue.x), double(v.blue.y), double(v.white.x), double(v.white.y));
        return buf;
    }
    if (auto m = dynamic_cast<const Imf::M44fAttribute*>(&a)) {
        std::string out;
        for (int i = 0; i < 4; ++i)
            for (int j = 0; j < 4; ++j) {
                std::snprintf(buf, sizeof buf, "%s%g", out.empty() ? "" : " ",
                              double(m->value()[i][j]));
                out += buf;
            }
        return out;
    }
    if (auto v = dynamic_cast<const Imf::FloatVectorAttribute*>(&a)) {
        std::string out;
        for (float f : v->value()) {
            std::snprintf(buf, sizeof buf, "%s%g", out.empty() ? "" : ", ", double(f));
            out += buf;
        }
        return out;
    }
    return std::string("(") + a.typeName() + ")";
}

// OpenEXR's level sizes (ImfTiledMisc): floor or ceiling of size / 2^l, at least 1.
int level_size(int size, int l, bool round_up) {
    int s = round_up ? static_cast<int>((static_cast<int64_t>(size) + (int64_t(1) << l) - 1) >> l)
                     : size >> l;
    return std::max(1, s);
}
int level_count(int size, bool round_up) {
    int n = 0;
    if (round_up) {
        while ((int64_t(1) << n) < size) ++n;
    } else {
        while ((size >> (n + 1)) > 0) ++n;
    }
    return n + 1;
}

bool is_emissive(const std::string& name) {
    // S0.<λ>nm .. S3.<λ>nm (Fichet 2021 emissive/polarised channels)
    if (name.size() < 6 || name[0] != 'S' || name[1] < '0' || name[1] > '3' || name[2] != '.')
        return false;
    double l;
    return parse_reflective_channel("T" + name.substr(2), &l);
}

}  // namespace

void exr_quiet_errors(exr_const_context_t, exr_result_t, const char*) {}

// OpenEXR's partComplete() only looks for offsets never written; a file cut short (a copy
// interrupted, a full disk) keeps its whole table, pointing past its end, and its first level may
// still decode.
bool exr_chunks_within_file(const std::string& path) {
    struct stat st;
    if (::stat(path.c_str(), &st) != 0) return false;
    const uint64_t size = static_cast<uint64_t>(st.st_size);
    exr_context_initializer_t init = EXR_DEFAULT_CONTEXT_INITIALIZER;
    init.error_handler_fn = exr_quiet_errors;
    exr_context_t ctx = nullptr;
    if (exr_start_read(&ctx, path.c_str(), &init) != EXR_ERR_SUCCESS) return false;
    bool ok = true;
    auto inside = [&](exr_result_t r, const exr_chunk_info_t& c) {
        return r == EXR_ERR_SUCCESS && c.data_offset + c.packed_size <= size;
    };
    int parts = 0;
    exr_get_count(ctx, &parts);
    for (int p = 0; p < parts && ok; ++p) {
        exr_storage_t storage;
        if (exr_get_storage(ctx, p, &storage) != EXR_ERR_SUCCESS) {
            ok = false;
            break;
        }
        exr_attr_box2i_t dw;
        if (exr_get_data_window(ctx, p, &dw) != EXR_ERR_SUCCESS) {
            ok = false;
            break;
        }
        exr_chunk_info_t ci;
        if (storage == EXR_STORAGE_SCANLINE) {
            int32_t lines = 1;
            exr_get_scanlines_per_chunk(ctx, p, &lines);
            for (int64_t y = dw.min.y; y <= dw.max.y && ok; y += std::max(1, lines))
                ok = inside(exr_read_scanline_chunk_info(ctx, p, static_cast<int>(y), &ci), ci);
        } else if (storage == EXR_STORAGE_TILED) {
            int32_t lx = 0, ly = 0;
            uint32_t tx = 0, ty = 0;
            exr_tile_level_mode_t mode;
            exr_tile_round_mode_t round;
            if (exr_get_tile_levels(ctx, p, &lx, &ly) != EXR_ERR_SUCCESS ||
                exr_get_tile_descriptor(ctx, p, &tx, &ty, &mode, &round) != EXR_ERR_SUCCESS) {
                ok = false;
                break;
            }
            for (int32_t a = 0; a < lx && ok; ++a)
                for (int32_t b = 0; b < ly && ok; ++b) {
                    if (mode == EXR_TILE_MIPMAP_LEVELS && a != b) continue;
                    int32_t w = 0, h = 0, tw = 0, th = 0;
                    if (exr_get_level_sizes(ctx, p, a, b, &w, &h) != EXR_ERR_SUCCESS ||
                        exr_get_tile_sizes(ctx, p, a, b, &tw, &th) != EXR_ERR_SUCCESS || tw <= 0 ||
                        th <= 0) {
                        ok = false;
                        break;
                    }
                    for (int32_t j = 0; j < (h + th - 1) / th && ok; ++j)
                        for (int32_t i = 0; i < (w + tw - 1) / tw && ok; ++i)
                            ok = inside(exr_read_tile_chunk_info(ctx, p, i, j, a, b, &ci), ci);
                }
        }
        // Deep parts: spectex never writes them; the readers refuse them.
    }
    exr_finish(&ctx);
    return ok;
}

SpectralExrInfo read_spectral_exr_info(const std::string& path) {
    // A regular file (never a FIFO, which would block, or a device), checked before reading.
    check_regular_file(path, file_limits::kImage, "an OpenEXR file");
    {
        std::ifstream f(path, std::ios::binary);
        unsigned char magic[4] = {0, 0, 0, 0};
        if (!f.read(reinterpret_cast<char*>(magic), 4) || magic[0] != 0x76 || magic[1] != 0x2f ||
            magic[2] != 0x31 || magic[3] != 0x01)
            throw Error(path + ": not an OpenEXR file");
    }
    SpectralExrInfo info;
    info.path = path;
    try {
        exr_preflight(path);
        Imf::MultiPartInputFile file(path.c_str());
        info.parts = file.parts();
        for (int part = 0; part < file.parts(); ++part)
            info.complete = info.complete && file.partComplete(part);
        info.complete = info.complete && exr_chunks_within_file(path);
        const Imf::Header& h = file.header(0);
        const Imath::Box2i& dw = h.dataWindow();
        const Imath::Box2i& disp = h.displayWindow();
        info.data_x0 = dw.min.x;
        info.data_y0 = dw.min.y;
        info.data_x1 = dw.max.x;
        info.data_y1 = dw.max.y;
        info.display_x0 = disp.min.x;
        info.display_y0 = disp.min.y;
        info.display_x1 = disp.max.x;
        info.display_y1 = disp.max.y;
        info.width = dw.max.x - dw.min.x + 1;
        info.height = dw.max.y - dw.min.y + 1;
        info.compression = compression_name(h.compression());
        if (h.hasTileDescription()) {
            info.tiled = true;
            info.tile_width = static_cast<int>(h.tileDescription().xSize);
            info.tile_height = static_cast<int>(h.tileDescription().ySize);
            const Imf::TileDescription& td = h.tileDescription();
            const bool up = td.roundingMode == Imf::ROUND_UP;
            info.level_rounding = up ? "up" : "down";
            const int w = info.width, ht = info.height;
            if (w > 0 && ht > 0 && td.mode == Imf::MIPMAP_LEVELS) {
                info.level_mode = "mipmap";
                const int n = level_count(std::max(w, ht), up);
                for (int l = 0; l < n; ++l)
                    info.levels.emplace_back(level_size(w, l, up), level_size(ht, l, up));
            } else if (w > 0 && ht > 0 && td.mode == Imf::RIPMAP_LEVELS) {
                info.level_mode = "ripmap";
                for (int l = 0, n = level_count(w, up); l < n; ++l)
                    info.rip_x.push_back(level_size(w, l, up));
                for (int l = 0, n = level_count(ht, up); l < n; ++l)
                    info.rip_y.push_back(level_size(ht, l, up));
            } else {
                info.levels.emplace_back(w, ht);
            }
        }
        bool r = false, g = false, b = false;
        for (auto it = h.channels().begin(); it != h.channels().end(); ++it) {
            std::string name = it.name();
            double l;
            if (parse_reflective_channel(name, &l)) {
                info.reflective.push_back({l, name, type_name(it.channel().type)});
            } else if (is_emissive(name)) {
                ++info.emissive_channels;
            } else if (name == "A") {
                info.alpha = true;
                info.alpha_type = type_name(it.channel().type);
            } else if (name == "R") {
                r = true;
            } else if (name == "G") {
                g = true;
            } else if (name == "B") {
                b = true;
            }
        }
        info.preview = r && g && b;
        for (auto it = h.begin(); it != h.end(); ++it) {
            std::string name = it.name();
            info.header.push_back(
                {name, it.attribute().typeName(), attribute_text(it.attribute())});
            if (name == "spectralLayoutVersion") {
                info.layout_version = attribute_text(it.attribute());
                continue;
            }
            if (name == "channels" || name == "dataWindow" || name == "displayWindow" ||
                name == "compression" || name == "lineOrder" || name == "pixelAspectRatio" ||
                name == "screenWindowCenter" || name == "screenWindowWidth" || name == "tiles")
                continue;
            info.attributes.emplace_back(name, attribute_text(it.attribute()));
        }
    } catch (const Error&) {
        throw;
    } catch (const std::exception& e) {
        throw Error(path + ": cannot read the OpenEXR header: " + e.what());
    }
    if (info.reflective.empty()) {
        throw Error(
            path + ": not a spectral reflectance image (no T.<wavelength>nm channels" +
            std::string(info.emissive_channels ? "; it has emissive S0-S3 channels only)" : ")"));
    }
    std::sort(info.reflective.begin(), info.reflective.end(),
              [](const SpectralBin& a, const SpectralBin& b) { return a.lambda < b.lambda; });
    for (size_t i = 1; i < info.reflective.size(); ++i)
        if (std::abs(info.reflective[i].lambda - info.reflective[i - 1].lambda) <= 1e-6)
            throw Error(path + ": channels " + info.reflective[i - 1].channel + " and " +
                        info.reflective[i].channel + " name the same wavelength");
    info.sample_type = info.reflective[0].type;
    for (const auto& bin : info.reflective)
        if (bin.type != info.sample_type) info.sample_type = "mixed";
    return info;
}

}  // namespace spectex
