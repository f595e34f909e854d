#pragma once
// Linearisation with OpenColorIO: the input colour space -> linear Rec.709 (sRGB primaries, D65).
#include <memory>
#include <string>
#include <vector>

#include "io/image_source.h"

namespace spectex {

struct ColourRequest {
    std::string data_dir;         // shipped config lives here
    std::string config_override;  // --config; empty: $OCIO, else the shipped config
    std::string colorspace;       // --colorspace; empty: what the file states, then file rules
    std::string file_path;        // for the config's file_rules
    ColourTags tags;              // what the file says of its colour (io/image_source.h)
};

class Linearizer {
  public:
    // Throws Error with the cause (unknown colour space with suggestions, bad config, ...).
    static Linearizer make(const ColourRequest& req);

    const std::string& input_space() const { return input_space_; }
    const std::string& config_path() const { return config_path_; }
    // Where the config came from: "--config", "$OCIO" or "shipped".
    const std::string& config_from() const { return config_from_; }
    // The config's name and description ("name: description"; either alone when the other is
    // empty).
    const std::string& config_name() const { return config_name_; }
    // Where the colour space came from, first that applies:
    //   "--colorspace"
    //   "ICC profile 'Adobe RGB (1998)'"              the embedded profile, named by the config
    //   "OpenEXR chromaticities (ACES AP1)"          primaries the file states
    //   "file metadata: sRGB chunk (sRGB)"           a tag the file carries (PNG sRGB/gAMA chunk,
    //                                                Exif ColorSpace, DPX transfer, ...)
    //   "config file rule 'OpenEXR'"                 a rule of the config other than its default
    //   "OpenImageIO's default for png files (sRGB)"  what the reader assumes
    //   "config file rule 'Default'"                 the config's default rule
    // When the file states a colour space the config cannot name (an ICC profile "ProPhoto RGB",
    // primaries of no known space), the fallback's origin is followed by "; not the file's ..."
    // and warnings() says so.
    const std::string& how_chosen() const { return how_; }
    // What the choice could not honour (an ICC profile or tag the config cannot name, a damaged
    // profile): one sentence each, naming what the file states and suggesting --colorspace.
    const std::vector<std::string>& warnings() const { return warnings_; }
    // The file rule that chose the input space ("" when --colorspace or metadata did), and whether
    // it is the config's default rule (the one that matches every file no other rule names).
    const std::string& file_rule() const { return rule_; }
    bool by_default_rule() const { return default_rule_; }
    // Whether the input space is scene-linear, as OCIO defines it: scene-referred, not data, and
    // its transform to linear Rec.709 linear (f(a x + b y) = a f(x) + b f(y), measured, whatever
    // the space is called or tagged).
    bool scene_linear() const { return scene_linear_; }
    bool is_identity() const { return identity_; }
    // What the config does to this file: OpenColorIO's cache ID of the processor from the input
    // space to linear Rec.709 (the bridge through the shipped config included). It changes with
    // the transform (a curve's gamma, a matrix, a LUT's values), not with the config's comments,
    // order, description or colour spaces this file does not use. Recorded as
    // spectex:colorTransform; --update compares it (colour_transform_id below).
    const std::string& transform_id() const { return transform_id_; }

    // In place on `pixels` packed RGBA float pixels (alpha passes through).
    void apply_rgba(float* rgba, long pixels) const;
    // The inverse, linear Rec.709 -> the input colour space, through the config's own inverse
    // transform (so that re-encoding undoes exactly what apply_rgba did); verify uses it to check
    // that colours re-encode to the source's codes, for any colour space of any config. False when
    // the config cannot invert the transform (encode_rgba then throws).
    bool can_encode() const;
    void encode_rgba(float* rgba, long pixels) const;

    // For integer sources of at most 16 bits, read as float by OpenImageIO: each channel then
    // takes at most 2^bits values, and when the transform has no channel crosstalk (a curve per
    // channel, as sRGB's) apply_rgba looks them up in a table made by OCIO itself on those exact
    // values. A value not in the table still goes through OCIO: the result is the same bits.
    // Returns whether the table is used.
    bool use_code_table(int bits);
    // After use_code_table(bits) returned true: the linear value of every code, channel by
    // channel (out[3 * i + c] for code i in channel c), exactly what apply_rgba gives a pixel
    // holding those codes; else empty.
    std::vector<float> code_values() const;

    Linearizer();
    ~Linearizer();
    Linearizer(Linearizer&&) noexcept;
    Linearizer& operator=(Linearizer&&) noexcept;

  private:
    struct Impl;
    std::unique_ptr<Impl> impl_;
    std::string input_space_, config_path_, config_from_, config_name_, how_, rule_, transform_id_;
    std::vector<std::string> warnings_;
    bool identity_ = false, default_rule_ = false, scene_linear_ = false;
};

// The linear value of every 8-bit code of the config's sRGB texture space (the space a PNG read as
// sRGB gets: OpenImageIO's hint "sRGB" named through the config), channel by channel, as a bake
// decodes an 8-bit sRGB texture: the colours the precision budget measures
// (PrecisionRequest::codes). Empty when the config has no such space, or its transform mixes the
// channels (a bake then decodes each pixel through OpenColorIO, not by code): the budget then
// measures IEC 61966-2-1's values. config_override as ColourRequest's.
std::vector<float> srgb_code_values(const std::string& data_dir,
                                    const std::string& config_override);

// The colour space `req` chooses and the transform_id() of its processor, as Linearizer::make would
// find them, without building the CPU processors: for --update, which asks it of every file of a
// batch (the config is parsed once, OCIO keeps its processors). Throws Error as make() does.
struct ColourTransform {
    std::string space, id;
};
ColourTransform colour_transform(const ColourRequest& req);

// The facts of a file's colour tags that choose its colour space (format, OpenImageIO's hint and
// what stated it, the ICC profile's description, OpenEXR chromaticities) as one line of JSON,
// recorded as spectex:inputColorSpaceMetadata, and back: --update chooses the space again from
// them without reading the file. A record that is not such JSON gives no tags.
std::string colour_tags_record(const ColourTags& tags);
ColourTags colour_tags_from_record(const std::string& text);

// Closest names (colour spaces and aliases) to `name` in a config, for "did you mean" messages.
std::vector<std::string> close_colour_space_names(const std::vector<std::string>& known,
                                                  const std::string& name, size_t max = 3);
// The same, preferring names of the same kind: `linear[i]` says whether known[i] is a linear
// space (1), an encoded one (0) or unknown (-1); a name whose words say "linear" (Linear, lin_,
// ACEScg, ...) or "encoded" (sRGB, Gamma, Encoded, _tx, Texture, log, ...) is offered spaces of its
// kind first, so that "sRGB Encoded Rec.2020" is not answered with "Linear Rec.2020" alone.
std::vector<std::string> close_colour_space_names(const std::vector<std::string>& known,
                                                  const std::vector<int>& linear,
                                                  const std::string& name, size_t max = 3);
// What the words of a colour space name say: 1 linear, 0 encoded, -1 neither.
int name_says_linear(const std::string& name);

}  // namespace spectex

namespace spectex {
// How far (linear RGB, per channel, for colours in [0, 1]) what a config does may be from the
// conversion it stands for and still be that conversion: what the rounded matrices published
// configs carry give, with a margin. Measured on them (docs/colour-spaces.md, "Config
// arithmetic"), the worst is 2.4e-4: the 7-digit sRGB -> AP0 matrix published with ACES 1.x
// against the OCIO 2 studio configs' AP0 -> Rec.709 (2.0e-4 against the shipped config's). Their
// digits are not the cause: 7 significant digits are within 4e-7 of the exact matrix, 6 (ACES
// 1.2's) within 5e-6, a product of two such (ACES 1.2's AP0 -> XYZ -> sRGB) within 1e-5. Their
// derivations are: IEC 61966-2-1's XYZ -> sRGB matrix, given to 4 decimals and behind the shipped
// config's matrices (through colour-science), is 1.6e-4 from the one the primaries give, which the
// studio configs and OpenColorIO's builtins use. float32 adds 1e-6 at most (rows of the AP0 ->
// Rec.709 matrix sum to at most 4.05 in magnitude, a few ulps each). 5e-4 is twice the worst; the
// spaces near sRGB that are not it are further: Rec.709 at gamma 2.2 (the nearest) is 8.1e-3 from
// the sRGB curve at the codes srgb_texture_space tries, at gamma 2.4 2.5e-2, the sRGB curve on P3
// primaries 0.22.
inline constexpr float kConfigArithmeticTolerance = 5e-4f;

// A colour space of that config which decodes like an sRGB texture (the IEC 61966-2-1 curve on
// Rec.709 primaries, D65) to within kConfigArithmeticTolerance, found by its transform, not its
// name; "" when it has none. For a --colorspace suggestion: it builds a processor per colour
// space, so call it once, not per file.
std::string srgb_texture_space(const std::string& data_dir, const std::string& config_override);
}  // namespace spectex
