#pragma once
// --update's judgement: the settings hash an output records, and whether an output need not be
// baked again (its settings, its colour transform, its source's identity). docs/provenance.md.
#include <string>

#include "pipeline/bake.h"

namespace spectex {

// Hash of every setting that can change the output's pixels or layout (not threads, jobs, verbosity
// or the command line): "fnv1a64:<hex>". The OCIO config is not in it: what the config does to a
// file is its spectex:colorTransform, compared file by file (check_update), so that a comment, a
// reordering or a colour space the file does not use changes nothing.
std::string settings_hash(const BakeSettings& s);
// The hash as spectex made it before it recorded spectex:colorTransform: the same settings, then
// the config's path and bytes. Outputs that record no colour transform are judged with it.
std::string legacy_settings_hash(const BakeSettings& s);

// --update: whether `output` need not be baked again from `input` with settings `s` (whose
// settings_hash and legacy_settings_hash are set). It must be a readable OpenEXR (only its header
// is read) carrying the same spectex:settingsHash, the same spectex:colorTransform as the config
// gives the colour space chosen for `input` now (chosen again as the bake chose it, from the
// metadata the header recorded: io/linearizer.h colour_transform), and the identity of the source
// it was baked from (io/source_identity.h). An output that records no colour transform (an older
// spectex's) is judged by legacy_settings_hash instead: kept while the config's bytes are the
// same, rebaked once when they changed. Up to date when the source has the recorded size and
// modification time; when only the time differs (a `touch`, a checkout), the source's bytes are
// hashed (read, not decoded) and compared with the recorded hash. Anything else rebuilds: a
// missing or unreadable output, other settings, another size or other bytes, and outputs made
// before spectex recorded its source's identity.
struct UpdateCheck {
    bool up_to_date = false;
    std::string reason;  // why it is up to date (for --json and --verbose), or why not
};
UpdateCheck check_update(const std::string& input, const std::string& output,
                         const BakeSettings& s);

}  // namespace spectex
