#include "pipeline/plot.h"

#include <algorithm>
#include <cmath>
#include <cstdio>
#include <sstream>

#include "base/error.h"
#include "base/text.h"
#include "io/atomic_file.h"
#include "io/spectral_reader.h"
#include "pipeline/look.h"
#include "spectral/spectrum.h"
#include "spectral/wavelength_grid.h"

namespace spectex {

namespace {

// Text for an XML 1.0 document declared UTF-8: one_line first (control bytes and bytes that are
// not UTF-8, such as a Latin-1 file name, become \xNN; line breaks "; "), then the markup
// characters as entities, and the two non-characters XML forbids (U+FFFE, U+FFFF) as \uXXXX.
std::string xml(const std::string& raw) {
    const std::string s = one_line(raw);
    std::string o;
    for (size_t i = 0; i < s.size(); ++i) {
        const char c = s[i];
        switch (c) {
            case '&':
                o += "&amp;";
                break;
            case '<':
                o += "&lt;";
                break;
            case '>':
                o += "&gt;";
                break;
            case '"':
                o += "&quot;";
                break;
            default:
                if (s.compare(i, 2, "\xEF\xBF") == 0 && i + 2 < s.size() &&
                    (s[i + 2] == '\xBE' || s[i + 2] == '\xBF')) {
                    o += s[i + 2] == '\xBE' ? "\\ufffe" : "\\uffff";
                    i += 2;
                } else {
                    o += c;
                }
        }
    }
    return o;
}

std::string f(double v) {
    char buf[32];
    std::snprintf(buf, sizeof buf, "%.2f", v);
    return buf;
}

std::string rgb_hex(const int* c) {
    char buf[16];
    std::snprintf(buf, sizeof buf, "#%02x%02x%02x", c[0], c[1], c[2]);
    return buf;
}

// A tick step of 1, 2 or 5 times a power of ten giving about `target` ticks over `range`.
double nice_step(double range, int target) {
    const double raw = range / target, p = std::pow(10.0, std::floor(std::log10(raw)));
    for (double m : {1.0, 2.0, 5.0, 10.0})
        if (raw <= m * p) return m * p;
    return 10 * p;
}

// What the plot shows: the file's wavelengths, the pixels' spectra and colours, the light.
struct PlotData {
    std::vector<double> lambda;
    std::vector<PixelSpectrum> px;
    std::vector<PixelColour> colours;  // each pixel's colour under D65
    Spectrum light;                    // empty without --light
};

PlotData read_plot_data(const std::string& exr_path, const std::vector<std::pair<int, int>>& xy,
                        const PlotSettings& s) {
    SpectralReader reader(exr_path);
    PlotData d;
    d.lambda = reader.wavelengths();
    std::vector<std::string> lights{"D65"};
    Viewer v;
    try {
        v = Viewer::make(s.data_dir, s.observer, d.lambda, lights);
        if (!s.light.empty()) d.light = load_illuminant(s.data_dir, s.light);
    } catch (const Error& e) {
        throw Error(exr_path + ": " + e.what());
    }
    d.px = reader.read_pixels(xy);
    const bool divide = reader.alpha() == AlphaKind::Associated;
    for (const auto& p : d.px)
        d.colours.push_back(colour_of(v, v.lights[0], p.values.data(), divide ? p.alpha : 1.0));
    return d;
}

// The plot area in SVG units and the maps from wavelength and reflectance to it.
struct Frame {
    double x_lo = 0, x_hi = 1, y_step = 1, y_hi = 1;
    double W = 0, H = 0, L = 70, R = 260, T = 40, B = 60;
    double pw = 0, ph = 0;
    double X(double l) const { return L + (l - x_lo) / (x_hi - x_lo) * pw; }
    double Y(double r) const { return T + ph - std::min(std::max(r, 0.0), y_hi) / y_hi * ph; }
};

Frame frame_for(const PlotData& d, const PlotSettings& s) {
    Frame fr;
    fr.x_lo = d.lambda.front();
    fr.x_hi = d.lambda.size() > 1 ? d.lambda.back() : d.lambda.front() + 1;
    double vmax = 1.0;
    for (const auto& p : d.px)
        for (float val : p.values)
            if (std::isfinite(val)) vmax = std::max(vmax, static_cast<double>(val));
    fr.y_step = nice_step(vmax, 5);
    fr.y_hi = std::ceil(vmax / fr.y_step - 1e-9) * fr.y_step;
    fr.W = s.width;
    fr.H = s.height;
    fr.pw = fr.W - fr.L - fr.R;
    fr.ph = fr.H - fr.T - fr.B;
    return fr;
}

void write_header(std::ostream& o, const std::string& exr_path, const PlotSettings& s,
                  const Frame& fr) {
    const std::string title = s.title.empty() ? exr_path : s.title;
    o << "<?xml version=\"1.0\" encoding=\"UTF-8\" standalone=\"no\"?>\n"
      << "<svg xmlns=\"http://www.w3.org/2000/svg\" version=\"1.1\" width=\"" << s.width
      << "\" height=\"" << s.height << "\" viewBox=\"0 0 " << s.width << " " << s.height
      << "\" font-family=\"sans-serif\" font-size=\"12\">\n"
      << "<title>" << (s.title.empty() ? "Spectra of " : "") << xml(title) << "</title>\n"
      << "<rect x=\"0\" y=\"0\" width=\"" << s.width << "\" height=\"" << s.height
      << "\" fill=\"#ffffff\"/>\n"
      << "<text x=\"" << f(fr.L) << "\" y=\"24\" font-size=\"14\">" << xml(title) << "</text>\n";
}

// The light's spectrum in the background, scaled so that its peak on the plotted range is the top.
void write_light(std::ostream& o, const Spectrum& light, const Frame& fr) {
    double peak = 0;
    std::vector<std::pair<double, double>> pts;
    for (size_t i = 0; i < light.lambda.size(); ++i)
        if (light.lambda[i] >= fr.x_lo && light.lambda[i] <= fr.x_hi &&
            std::isfinite(light.value[i])) {
            pts.emplace_back(light.lambda[i], light.value[i]);
            peak = std::max(peak, light.value[i]);
        }
    if (peak > 0 && pts.size() > 1) {
        o << "<path class=\"light\" fill=\"none\" stroke=\"#c8c8c8\" stroke-width=\"1.5\" d=\"";
        for (size_t i = 0; i < pts.size(); ++i)
            o << (i ? " L" : "M") << f(fr.X(pts[i].first)) << ","
              << f(fr.Y(pts[i].second / peak * fr.y_hi));
        o << "\"/>\n";
    }
}

// Axes, grid, ticks and the axis labels.
void write_axes(std::ostream& o, const Frame& fr) {
    const double L = fr.L, T = fr.T, pw = fr.pw, ph = fr.ph;
    o << "<g class=\"axes\" stroke=\"#000000\" stroke-width=\"1\">\n"
      << "<line x1=\"" << f(L) << "\" y1=\"" << f(T + ph) << "\" x2=\"" << f(L + pw) << "\" y2=\""
      << f(T + ph) << "\"/>\n<line x1=\"" << f(L) << "\" y1=\"" << f(T) << "\" x2=\"" << f(L)
      << "\" y2=\"" << f(T + ph) << "\"/>\n</g>\n<g class=\"ticks\" font-size=\"11\">\n";
    const double x_step = nice_step(fr.x_hi - fr.x_lo, 8);
    for (double t = std::ceil(fr.x_lo / x_step - 1e-9) * x_step; t <= fr.x_hi + 1e-9; t += x_step)
        o << "<line x1=\"" << f(fr.X(t)) << "\" y1=\"" << f(T + ph) << "\" x2=\"" << f(fr.X(t))
          << "\" y2=\"" << f(T + ph + 5) << "\" stroke=\"#000000\"/><text x=\"" << f(fr.X(t))
          << "\" y=\"" << f(T + ph + 18) << "\" text-anchor=\"middle\">" << format_wavelength(t)
          << "</text>\n";
    for (int i = 0; i * fr.y_step <= fr.y_hi + 1e-9; ++i) {
        const double t = i * fr.y_step;
        char lab[32];
        std::snprintf(lab, sizeof lab, "%g", std::round(t * 1e6) / 1e6);
        o << "<line x1=\"" << f(L - 5) << "\" y1=\"" << f(fr.Y(t)) << "\" x2=\"" << f(L + pw)
          << "\" y2=\"" << f(fr.Y(t)) << "\" stroke=\"" << (i ? "#e4e4e4" : "#000000")
          << "\"/><text x=\"" << f(L - 8) << "\" y=\"" << f(fr.Y(t) + 4)
          << "\" text-anchor=\"end\">" << lab << "</text>\n";
    }
    o << "</g>\n"
      << "<text class=\"xlabel\" x=\"" << f(L + pw / 2) << "\" y=\"" << f(fr.H - 18)
      << "\" text-anchor=\"middle\">Wavelength (nm)</text>\n"
      << "<text class=\"ylabel\" x=\"18\" y=\"" << f(T + ph / 2)
      << "\" text-anchor=\"middle\" transform=\"rotate(-90 18 " << f(T + ph / 2)
      << ")\">Reflectance</text>\n";
}

// A pixel's line colour: its sRGB colour, grey where it has none.
std::string line_colour(const PixelColour& c) {
    return c.defined ? rgb_hex(c.srgb) : std::string("#808080");
}

// The curves: a dark outline under the pixel's own colour; the pen lifts at values not finite.
void write_curves(std::ostream& o, const PlotData& d, const Frame& fr) {
    o << "<g class=\"curves\" fill=\"none\" stroke-linejoin=\"round\">\n";
    for (size_t i = 0; i < d.px.size(); ++i) {
        const PixelSpectrum& p = d.px[i];
        std::ostringstream path;
        bool pen = false;
        for (size_t k = 0; k < d.lambda.size(); ++k) {
            const double val = p.values[k];
            if (!std::isfinite(val)) {
                pen = false;
                continue;
            }
            path << (pen ? " L" : (k ? " M" : "M")) << f(fr.X(d.lambda[k])) << "," << f(fr.Y(val));
            pen = true;
        }
        const std::string id = std::to_string(p.x) + "," + std::to_string(p.y);
        o << "<g class=\"pixel\"><title>pixel " << id << "</title>"
          << "<path class=\"outline\" stroke=\"#202020\" stroke-width=\"4\" d=\"" << path.str()
          << "\"/>"
          << "<path class=\"spectrum\" stroke=\"" << line_colour(d.colours[i])
          << "\" stroke-width=\"2\" d=\"" << path.str() << "\"/></g>\n";
    }
    o << "</g>\n";
}

// The legend: each pixel with its sRGB code, the light, and the conditions of the colours.
void write_legend(std::ostream& o, const PlotData& d, const PlotSettings& s, const Frame& fr) {
    const double lx = fr.L + fr.pw + 20;
    double ly = fr.T + 6;
    o << "<g class=\"legend\" font-size=\"11\">\n";
    for (size_t i = 0; i < d.px.size(); ++i) {
        const PixelColour& c = d.colours[i];
        std::string text = "pixel " + std::to_string(d.px[i].x) + "," + std::to_string(d.px[i].y);
        if (c.defined)
            text += "  sRGB " + std::to_string(c.srgb[0]) + " " + std::to_string(c.srgb[1]) + " " +
                    std::to_string(c.srgb[2]);
        else
            text += "  (A = 0)";
        o << "<rect x=\"" << f(lx) << "\" y=\"" << f(ly - 10)
          << "\" width=\"14\" height=\"14\" fill=\"" << line_colour(c)
          << "\" stroke=\"#202020\" stroke-width=\"1\"/><text x=\"" << f(lx + 20) << "\" y=\""
          << f(ly + 1) << "\">" << xml(text) << "</text>\n";
        ly += 20;
    }
    if (!s.light.empty()) {
        o << "<line x1=\"" << f(lx) << "\" y1=\"" << f(ly - 3) << "\" x2=\"" << f(lx + 14)
          << "\" y2=\"" << f(ly - 3) << "\" stroke=\"#c8c8c8\" stroke-width=\"2\"/><text x=\""
          << f(lx + 20) << "\" y=\"" << f(ly + 1) << "\">" << xml(s.light)
          << " (power, scaled)</text>\n";
        ly += 20;
    }
    o << "<text x=\"" << f(lx) << "\" y=\"" << f(ly + 6)
      << "\" font-size=\"10\" fill=\"#555555\">colours: D65, " << xml(s.observer) << "</text>\n";
    o << "</g>\n";
}

}  // namespace

std::string plot_svg(const std::string& exr_path, const std::vector<std::pair<int, int>>& xy,
                     const PlotSettings& s, PlotReport* report) {
    const PlotData d = read_plot_data(exr_path, xy, s);
    const Frame fr = frame_for(d, s);
    std::ostringstream o;
    write_header(o, exr_path, s, fr);
    if (!s.light.empty()) write_light(o, d.light, fr);
    write_axes(o, fr);
    write_curves(o, d, fr);
    write_legend(o, d, s, fr);
    o << "</svg>\n";
    if (report) {
        report->file = exr_path;
        report->curves = static_cast<int>(d.px.size());
        report->y_max = fr.y_hi;
    }
    return o.str();
}

PlotReport plot_file(const std::string& exr_path, const std::string& svg_path,
                     const std::vector<std::pair<int, int>>& xy, const PlotSettings& s) {
    PlotReport r;
    const std::string svg = plot_svg(exr_path, xy, s, &r);
    r.output = svg_path;
    write_text_atomically(svg_path, svg);
    return r;
}

}  // namespace spectex
