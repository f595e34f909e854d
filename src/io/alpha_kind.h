#pragma once
// What an image's alpha channel means: none, associated (colour premultiplied by A: OpenEXR's
// convention and OpenImageIO's), or unassociated (straight colour). Read from a source's metadata
// or an EXR's spectex:alpha; written to reports as to_string's word.

namespace spectex {

enum class AlphaKind { None, Associated, Unassociated };

// "none", "associated", "unassociated": the words of the JSON reports, `info` and spectex:alpha.
inline const char* to_string(AlphaKind a) {
    switch (a) {
        case AlphaKind::None:
            return "none";
        case AlphaKind::Associated:
            return "associated";
        case AlphaKind::Unassociated:
            return "unassociated";
    }
    return "none";
}

}  // namespace spectex
