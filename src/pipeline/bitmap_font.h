#pragma once
// A tiny built-in 5x7 pixel font for labels on rendered pictures (no font files, same pixels on
// every machine). Upper-case letters, digits and a few signs; lower case is drawn as upper case,
// anything else as '?'.
#include <cstdint>
#include <string>

namespace spectex {

constexpr int kGlyphWidth = 5, kGlyphHeight = 7, kGlyphAdvance = 6;

// Row r (0 = top) of the glyph for c: bit 4 is the leftmost column.
uint8_t glyph_row(char c, int r);

// Width in pixels of `text` drawn at `scale` (advance 6 per character, no trailing gap).
int text_width(const std::string& text, int scale);

// Draws `text` into an interleaved 8-bit image (nch channels, row stride in bytes) with its
// top-left corner at (x, y), each font pixel a scale x scale square, clipped to [0, max_x) x [0,
// h).
void draw_text(uint8_t* image, int w, int h, int nch, size_t stride, int x, int y,
               const std::string& text, int scale, const uint8_t* colour, int max_x);

}  // namespace spectex
