#pragma once
// What an image's alpha channel means: none, associated (colour premultiplied by A: OpenEXR's
// convention and OpenImageIO's), or unassociated (straight colour). Read from a source's metadata
// or an EXR's spectex:alpha; written to reports as to_string's word.

#include "base/enum_names.h"

namespace spectex {

enum class AlphaKind { None, Associated, Unassociated };

// "none", "associated", "unassociated": the words of the JSON reports, `info` and spectex:alpha.
inline constexpr EnumNames<AlphaKind, 3> kAlphaKindNames{
    {{{AlphaKind::None, "none"},
      {AlphaKind::Associated, "associated"},
      {AlphaKind::Unassociated, "unassociated"}}}};
inline const char* to_string(AlphaKind a) { return kAlphaKindNames.name(a); }

}  // namespace spectex
