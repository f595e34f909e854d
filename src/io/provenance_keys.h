#pragma once
// The names of the spectex:* header attributes, which record how a file was baked (README, "The
// output file"): written by the bake (pipeline/bake.cpp), read by `info`, `verify` and `bake
// --update`. Every use names the constant, never the string. They are names in a file format, so
// they live in io/; a spectral method describes itself with MethodFacts
// (spectral/spectral_method.h) and method_fact_key below names each.
#include "spectral/spectral_method.h"

namespace spectex {
namespace provenance_key {

constexpr const char* kPrefix = "spectex:";  // every key below starts with it

// The bake: tool, command, input and output grid.
constexpr const char* kVersion = "spectex:version";
constexpr const char* kCommandLine = "spectex:commandLine";
constexpr const char* kSource = "spectex:source";  // as given on the command line
// The same file found from anywhere: absolute and normalised, and relative to the output's folder
// (which survives moving the source and output trees together to another machine or mount).
constexpr const char* kSourceAbsolute = "spectex:sourceAbsolute";
constexpr const char* kSourceFromOutput = "spectex:sourceFromOutput";
constexpr const char* kWavelengths = "spectex:wavelengths";
constexpr const char* kWavelengthList = "spectex:wavelengthList";
constexpr const char* kObserver = "spectex:observer";
constexpr const char* kIlluminant = "spectex:illuminant";
// The colour: the input's space and how it was chosen, the OCIO config.
constexpr const char* kInputColorSpace = "spectex:inputColorSpace";
constexpr const char* kInputColorSpaceFrom = "spectex:inputColorSpaceFrom";
// The colour space the input's own metadata named (OpenImageIO's oiio:ColorSpace; "" when none),
// whether or not the config knew it: --update chooses the space again with it.
constexpr const char* kInputColorSpaceMetadata = "spectex:inputColorSpaceMetadata";
constexpr const char* kConfig = "spectex:config";
constexpr const char* kConfigFrom = "spectex:configFrom";
constexpr const char* kConfigName = "spectex:configName";
constexpr const char* kConfigChecksum = "spectex:configChecksum";
// What the config does to this file: OpenColorIO's cache ID of the processor from the input space
// to linear Rec.709 (io/linearizer.h, transform_id()). --update compares it instead of the config's
// bytes; a file without it was baked when the settings hash still held the config's bytes.
constexpr const char* kColorTransform = "spectex:colorTransform";
// Pixel policies and the encoding.
constexpr const char* kAlpha = "spectex:alpha";
constexpr const char* kOutOfRange = "spectex:outOfRange";
constexpr const char* kNan = "spectex:nan";
constexpr const char* kZipLevel = "spectex:zipLevel";
constexpr const char* kHalfRounding = "spectex:halfRounding";
// Written only when the compression changes samples of the file's type (bake --allow-lossy):
// "b44 (lossy for half)". verify names it when a gate fails.
constexpr const char* kLossyCompression = "spectex:lossyCompression";
// --update: the settings and the source's identity (io/source_identity.h).
constexpr const char* kSettingsHash = "spectex:settingsHash";
constexpr const char* kSourceSize = "spectex:sourceSize";
constexpr const char* kSourceMtime = "spectex:sourceMtime";
constexpr const char* kSourceHash = "spectex:sourceHash";
// --wavelengths auto: the plan that chose the grid.
constexpr const char* kPlanLights = "spectex:planLights";
constexpr const char* kPlanMaxDe = "spectex:planMaxDe";
constexpr const char* kPlanReconstruction = "spectex:planReconstruction";
constexpr const char* kPlanRange = "spectex:planRange";
constexpr const char* kPlanWorstDe = "spectex:planWorstDe";
constexpr const char* kPlanGrids = "spectex:planGrids";
// --precision auto: the budget and the mantissa bits kept per bin (docs/precision.md).
constexpr const char* kPrecision = "spectex:precision";  // "auto" (absent: full half)
constexpr const char* kPrecisionMaxDe = "spectex:precisionMaxDe";
constexpr const char* kPrecisionLights = "spectex:precisionLights";
constexpr const char* kPrecisionBits = "spectex:precisionBits";  // "10 10 9 …", one per bin
constexpr const char* kPrecisionWorstDe = "spectex:precisionWorstDe";
// Per light, the 8-bit sRGB code whose figure that is: "D65 #rrggbb, A #rrggbb, ...".
constexpr const char* kPrecisionWorstCode = "spectex:precisionWorstCode";
constexpr const char* kPrecisionSample = "spectex:precisionSample";
// The spectral method (SpectralMethod::provenance()).
constexpr const char* kMethod = "spectex:method";
constexpr const char* kBasis = "spectex:basis";
constexpr const char* kBasisSource = "spectex:basisSource";
constexpr const char* kBasisChecksum = "spectex:basisChecksum";
constexpr const char* kLatticeSize = "spectex:latticeSize";
constexpr const char* kVertexPrior = "spectex:vertexPrior";
constexpr const char* kJhTableResolution = "spectex:jhTableResolution";
constexpr const char* kMethodSource = "spectex:methodSource";
constexpr const char* kMethodChecksum = "spectex:methodChecksum";
// What rebuilds the spectra from RGB (io/rebuild_record.h): rule, lattice breakpoints, weights of
// a spectrum's linear RGB, table (base64 of its encoding), the table's encoding and the checksum.
constexpr const char* kRebuild = "spectex:rebuild";
constexpr const char* kRebuildAxis = "spectex:rebuildAxis";
constexpr const char* kRebuildToRgb = "spectex:rebuildToRgb";
constexpr const char* kRebuildTable = "spectex:rebuildTable";
constexpr const char* kRebuildTableEncoding = "spectex:rebuildTableEncoding";
constexpr const char* kRebuildChecksum = "spectex:rebuildChecksum";

// Every key above, for checks that a file records nothing else.
constexpr const char* kAll[] = {
    kVersion,
    kCommandLine,
    kSource,
    kSourceAbsolute,
    kSourceFromOutput,
    kWavelengths,
    kWavelengthList,
    kObserver,
    kIlluminant,
    kInputColorSpace,
    kInputColorSpaceFrom,
    kInputColorSpaceMetadata,
    kConfig,
    kConfigFrom,
    kConfigName,
    kConfigChecksum,
    kColorTransform,
    kAlpha,
    kOutOfRange,
    kNan,
    kZipLevel,
    kHalfRounding,
    kLossyCompression,
    kSettingsHash,
    kSourceSize,
    kSourceMtime,
    kSourceHash,
    kPlanLights,
    kPlanMaxDe,
    kPlanReconstruction,
    kPlanRange,
    kPlanWorstDe,
    kPlanGrids,
    kPrecision,
    kPrecisionMaxDe,
    kPrecisionLights,
    kPrecisionBits,
    kPrecisionWorstDe,
    kPrecisionWorstCode,
    kPrecisionSample,
    kMethod,
    kBasis,
    kBasisSource,
    kBasisChecksum,
    kLatticeSize,
    kVertexPrior,
    kJhTableResolution,
    kMethodSource,
    kMethodChecksum,
    kRebuild,
    kRebuildAxis,
    kRebuildToRgb,
    kRebuildTable,
    kRebuildTableEncoding,
    kRebuildChecksum,
};

}  // namespace provenance_key

// The attribute a method's fact (SpectralMethod::provenance()) is written under.
inline const char* method_fact_key(MethodFact fact) {
    switch (fact) {
        case MethodFact::Method:
            return provenance_key::kMethod;
        case MethodFact::Basis:
            return provenance_key::kBasis;
        case MethodFact::BasisSource:
            return provenance_key::kBasisSource;
        case MethodFact::BasisChecksum:
            return provenance_key::kBasisChecksum;
        case MethodFact::LatticeSize:
            return provenance_key::kLatticeSize;
        case MethodFact::VertexPrior:
            return provenance_key::kVertexPrior;
        case MethodFact::JhTableResolution:
            return provenance_key::kJhTableResolution;
        case MethodFact::MethodSource:
            return provenance_key::kMethodSource;
        case MethodFact::MethodChecksum:
            return provenance_key::kMethodChecksum;
    }
    return provenance_key::kMethod;  // not reached: the switch names every fact
}

}  // namespace spectex
