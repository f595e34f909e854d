#include "io/spectral_exr_info.h"

#include <ImfChannelList.h>
#include <ImfHeader.h>
#include <ImfMultiPartInputFile.h>
#include <ImfStringAttribute.h>
#include <ImfStringVectorAttribute.h>
#include <ImfTileDescriptionAttribute.h>
#include <ImfFloatAttribute.h>
#include <ImfIntAttribute.h>
#include <ImfFloatVectorAttribute.h>
#include <ImfVecAttribute.h>
#include <ImfBoxAttribute.h>
#include <ImfCompressionAttribute.h>
#include <Iex.h>
#include <sys/stat.h>

#include <algorithm>
#include <cerrno>
#include <cstdio>
#include <cstring>
#include <fstream>

#include "io/exr_preflight.h"
#include "spectral/bounded_read.h"
#include "spectral/error.h"
#include "spectral/wavelength_grid.h"

namespace spectex {

namespace {

std::string type_name(Imf::PixelType t) {
    switch (t) {
        case Imf::HALF: return "half";
        case Imf::FLOAT: return "float";
        case Imf::UINT: return "uint";
        default: return "unknown";
    }
}

std::string compression_name(Imf::Compression c) {
    switch (c) {
        case Imf::NO_COMPRESSION: return "none";
        case Imf::RLE_COMPRESSION: return "rle";
        case Imf::ZIPS_COMPRESSION: return "zips";
        case Imf::ZIP_COMPRESSION: return "zip";
        case Imf::PIZ_COMPRESSION: return "piz";
        case Imf::PXR24_COMPRESSION: return "pxr24";
        case Imf::B44_COMPRESSION: return "b44";
        case Imf::B44A_COMPRESSION: return "b44a";
        case Imf::DWAA_COMPRESSION: return "dwaa";
        case Imf::DWAB_COMPRESSION: return "dwab";
        default: return "unknown";
    }
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
    return std::string("(") + a.typeName() + ")";
}

bool is_emissive(const std::string& name) {
    // S0.<λ>nm .. S3.<λ>nm (Fichet 2021 emissive/polarised channels)
    if (name.size() < 6 || name[0] != 'S' || name[1] < '0' || name[1] > '3' || name[2] != '.') return false;
    double l;
    return parse_reflective_channel("T" + name.substr(2), &l);
}

}  // namespace

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
            if (name == "spectralLayoutVersion") {
                info.layout_version = attribute_text(it.attribute());
                continue;
            }
            if (name == "channels" || name == "dataWindow" || name == "displayWindow" || name == "compression" ||
                name == "lineOrder" || name == "pixelAspectRatio" || name == "screenWindowCenter" ||
                name == "screenWindowWidth" || name == "tiles")
                continue;
            info.attributes.emplace_back(name, attribute_text(it.attribute()));
        }
    } catch (const Error&) {
        throw;
    } catch (const std::exception& e) {
        throw Error(path + ": cannot read the OpenEXR header: " + e.what());
    }
    if (info.reflective.empty()) {
        throw Error(path + ": not a spectral reflectance image (no T.<wavelength>nm channels" +
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
