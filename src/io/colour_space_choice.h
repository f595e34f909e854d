#pragma once
// Which colour space a file is read in (io/colour_space_choice.cpp), apart from applying it
// (io/linearizer.cpp): what Linearizer::make and colour_transform share. Internal to io/; the
// public interface is io/linearizer.h.
#include <OpenColorIO/OpenColorIO.h>

#include <string>
#include <vector>

#include "io/linearizer.h"

namespace spectex {

// Names under which configs in the wild (ours, the ACES CG/Studio configs) call linear Rec.709.
extern const std::vector<std::string> kLinearRec709Names;

// The canonical name of the first of `names` (names, aliases or roles) the config has, or "".
std::string find_first(const OCIO_NAMESPACE::ConstConfigRcPtr& cfg,
                       const std::vector<std::string>& names);

// The input colour space of a request, first that applies: --colorspace; what the file states (its
// ICC profile, its OpenEXR chromaticities, a tag such as PNG's sRGB chunk) when the config can name
// it; a file rule of the config other than its default; what OpenImageIO assumes for the format;
// the default rule. Sets how it was chosen, the file rule, whether it is the default rule, and a
// warning when the file states a space the config cannot name. path names the config in messages.
// Throws Error.
std::string choose_space(const OCIO_NAMESPACE::ConstConfigRcPtr& cfg, const std::string& path,
                         const ColourRequest& req, std::string& how, std::string& rule_name,
                         bool& default_rule, std::vector<std::string>& warnings);

}  // namespace spectex
