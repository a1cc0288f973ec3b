// dwa_write: writes lossy DWAA / DWAB OpenEXR files through OpenEXR's own C++ library
// (Imf::RgbaOutputFile: R, G, B as half, the only channels DWA codes lossily), for the tests
// and the measurement of the loader's ringing treatment (tests/test_exr_ringing.c,
// scripts/dwa_bench.sh). Not part of envlight.
//
//   dwa_write OUT.exr dwaa|dwab|zip LEVEL IN.exr
//       IN (any OpenEXR file OpenEXR reads, R, G, B or Y) re-encoded; LEVEL is the header's
//       dwaCompressionLevel (OpenEXR's default 45; higher keeps less)
//   dwa_write OUT.exr dwaa|dwab|zip LEVEL --sun W H SKY X Y SUN [OX OY]
//       a W x H image of radiance SKY everywhere but pixel (X, Y), which holds SUN: a point
//       light that the 8 x 8 DCT of its block makes ring (on a black sky, at a high level);
//       the data window is (0, 0) - (W - 1, H - 1), the display window the same moved by
//       (OX, OY) (default 0, 0), so the codec's blocks start at (-OX, -OY) of the display
//   dwa_write OUT.pfm pfm 0 IN.exr
//       IN's values as OpenEXR decodes them (negative ones kept) as a PFM (float RGB, bottom
//       row first), for scripts that read them with no filling
//   dwa_write OUT.exr zip 0 --inf W H
//       a W x H image whose every channel is +Inf (half)
//   dwa_write OUT.exr zip 0 --windows DX0 DY0 DX1 DY1 WX0 WY0 WX1 WY1
//       display window (DX0, DY0) - (DX1, DY1), data window (WX0, WY0) - (WX1, WY1), every
//       stored pixel 1
#include <ImfArray.h>
#include <ImfHeader.h>
#include <ImfRgbaFile.h>
#include <half.h>

#include <cmath>
#include <cstddef>
#include <cstdio>
#include <cstdlib>
#include <cstring>
#include <exception>
#include <limits>
#include <stdexcept>
#include <vector>

namespace {

int usage()
{
    std::fprintf(stderr,
                 "usage: dwa_write OUT.exr dwaa|dwab|zip LEVEL IN.exr\n"
                 "       dwa_write OUT.pfm pfm 0 IN.exr\n"
                 "       dwa_write OUT.exr dwaa|dwab|zip LEVEL --sun W H SKY X Y SUN [OX OY]\n"
                 "       dwa_write OUT.exr zip 0 --inf W H\n"
                 "       dwa_write OUT.exr zip 0 --windows DX0 DY0 DX1 DY1 WX0 WY0 WX1 WY1\n");
    return 2;
}

void write(const char *out, Imf::Compression comp, float level, const Imath::Box2i &display,
           const Imath::Box2i &data, const std::vector<Imf::Rgba> &px)
{
    Imf::Header h(display, data);
    h.compression() = comp;
    h.dwaCompressionLevel() = level;
    Imf::RgbaOutputFile f(out, h, Imf::WRITE_RGB);
    int w = data.max.x - data.min.x + 1;
    f.setFrameBuffer(px.data() - data.min.x - (std::ptrdiff_t)data.min.y * w, 1, w);
    f.writePixels(data.max.y - data.min.y + 1);
}

/* IN's pixels (its data window) as a little-endian PFM, the bottom row first. */
void write_pfm(const char *out, const std::vector<Imf::Rgba> &px, int w, int h)
{
    FILE *f = std::fopen(out, "wb");
    if (!f)
        throw std::runtime_error("cannot create the file");
    std::fprintf(f, "PF\n%d %d\n-1\n", w, h);
    for (int y = h - 1; y >= 0; y--)
        for (int x = 0; x < w; x++) {
            const Imf::Rgba &p = px[(size_t)y * w + x];
            float v[3] = {p.r, p.g, p.b};
            std::fwrite(v, sizeof v, 1, f);
        }
    if (std::fclose(f) != 0)
        throw std::runtime_error("cannot write the file");
}

} // namespace

int main(int argc, char **argv)
{
    if (argc < 5)
        return usage();
    Imf::Compression comp = Imf::NO_COMPRESSION;
    bool pfm = !std::strcmp(argv[2], "pfm");
    if (pfm)
        ;
    else if (!std::strcmp(argv[2], "dwaa"))
        comp = Imf::DWAA_COMPRESSION;
    else if (!std::strcmp(argv[2], "dwab"))
        comp = Imf::DWAB_COMPRESSION;
    else if (!std::strcmp(argv[2], "zip"))
        comp = Imf::ZIP_COMPRESSION;
    else
        return usage();
    float level = (float)std::atof(argv[3]);
    try {
        if (!std::strcmp(argv[4], "--sun") && (argc == 11 || argc == 13)) {
            int w = std::atoi(argv[5]), h = std::atoi(argv[6]), x = std::atoi(argv[8]),
                y = std::atoi(argv[9]), ox = argc == 13 ? std::atoi(argv[11]) : 0,
                oy = argc == 13 ? std::atoi(argv[12]) : 0;
            float sky = (float)std::atof(argv[7]), sun = (float)std::atof(argv[10]);
            if (w <= 0 || h <= 0 || x < 0 || y < 0 || x >= w || y >= h)
                return usage();
            std::vector<Imf::Rgba> px((size_t)w * h, Imf::Rgba(sky, sky, sky, 1));
            px[(size_t)y * w + x] = Imf::Rgba(sun, sun, sun, 1);
            Imath::Box2i data(Imath::V2i(0, 0), Imath::V2i(w - 1, h - 1));
            Imath::Box2i display(Imath::V2i(ox, oy), Imath::V2i(ox + w - 1, oy + h - 1));
            write(argv[1], comp, level, display, data, px);
        } else if (!std::strcmp(argv[4], "--inf") && argc == 7) {
            int w = std::atoi(argv[5]), h = std::atoi(argv[6]);
            if (w <= 0 || h <= 0)
                return usage();
            half inf = std::numeric_limits<half>::infinity();
            std::vector<Imf::Rgba> px((size_t)w * h, Imf::Rgba(inf, inf, inf, 1));
            Imath::Box2i box(Imath::V2i(0, 0), Imath::V2i(w - 1, h - 1));
            write(argv[1], comp, level, box, box, px);
        } else if (!std::strcmp(argv[4], "--windows") && argc == 13) {
            int v[8];
            for (int i = 0; i < 8; i++)
                v[i] = std::atoi(argv[5 + i]);
            Imath::Box2i display(Imath::V2i(v[0], v[1]), Imath::V2i(v[2], v[3]));
            Imath::Box2i data(Imath::V2i(v[4], v[5]), Imath::V2i(v[6], v[7]));
            if (display.isEmpty() || data.isEmpty())
                return usage();
            size_t n = (size_t)(v[6] - v[4] + 1) * (size_t)(v[7] - v[5] + 1);
            std::vector<Imf::Rgba> px(n, Imf::Rgba(1, 1, 1, 1));
            write(argv[1], comp, level, display, data, px);
        } else if (argc == 5) {
            Imf::RgbaInputFile in(argv[4]);
            Imath::Box2i dw = in.dataWindow();
            int w = dw.max.x - dw.min.x + 1, h = dw.max.y - dw.min.y + 1;
            std::vector<Imf::Rgba> px((size_t)w * h);
            in.setFrameBuffer(px.data() - dw.min.x - (std::ptrdiff_t)dw.min.y * w, 1, w);
            in.readPixels(dw.min.y, dw.max.y);
            if (pfm)
                write_pfm(argv[1], px, w, h);
            else
                write(argv[1], comp, level, in.displayWindow(), dw, px);
        } else {
            return usage();
        }
    } catch (const std::exception &e) {
        std::fprintf(stderr, "dwa_write: %s: %s\n", argv[1], e.what());
        return 1;
    }
    return 0;
}
