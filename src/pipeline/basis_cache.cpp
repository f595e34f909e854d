#include "pipeline/basis_cache.h"

#include "base/memo.h"
#include "pipeline/table_memo.h"
#include "spectral/colorimetry.h"
#include "spectral/spectrum.h"

namespace spectex {

std::string FitSpec::describe() const {
    return primaries + " primaries, " + observer + ", " + illuminant + ", " + grid.describe() +
           ", " + to_string(objective) + (allow_infeasible ? ", infeasible allowed" : "");
}

Observer fit_observer(const FitSpec& spec) {
    return spec.observer_table ? *spec.observer_table
                               : *observer_table(spec.data_dir, spec.observer);
}

Spectrum fit_illuminant(const FitSpec& spec) {
    return spec.illuminant_table ? *spec.illuminant_table
                                 : *illuminant_table(spec.data_dir, spec.illuminant);
}

FitResult fit_basis_for(const FitSpec& spec) {
    static Memo<std::string, FitResult> memo;
    std::string key = spec.describe() + "|" + spec.data_dir;
    for (double l : spec.grid.lambda) key += "|" + format_wavelength(l);
    return memo.get(key, [&] {
        Observer obs = fit_observer(spec);
        Spectrum ill = fit_illuminant(spec);
        FitRequest req{Colorimetry::make(obs, ill, spec.grid, primaries_by_name(spec.primaries)),
                       spec.objective, spec.allow_infeasible};
        FitResult r = fit_basis(req);
        r.basis.name = "fit:" + to_string(spec.objective);
        return r;
    });
}

}  // namespace spectex
