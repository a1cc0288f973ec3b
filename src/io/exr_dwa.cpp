// DWAA / DWAB decoding through the OpenEXR C++ library (Imf::MultiPartInputFile, Imf::InputPart,
// Imf::FrameBuffer), for exr.c; see exr_dwa.h. The file is read from memory through an
// Imf::IStream. Every exception stops at the extern "C" functions and becomes a result code
// and the library's message.
#include "exr_dwa.h"

#include <ImfFrameBuffer.h>
#include <ImfHeader.h>
#include <ImfIO.h>
#include <ImfInputPart.h>
#include <ImfMultiPartInputFile.h>
#include <Iex.h>

#include <cstdio>
#include <cstring>
#include <exception>
#include <new>

namespace {

// The whole file in memory, as OpenEXR's IStream (ImfIO.h): read() throws on a short read.
class MemoryStream : public Imf::IStream {
  public:
    MemoryStream(const uint8_t *data, size_t size, const char *name)
        : Imf::IStream(name), data_(data), size_(size), pos_(0)
    {
    }
    bool read(char c[], int n) override
    {
        if (n < 0 || pos_ > size_ || (uint64_t)n > size_ - pos_)
            throw Iex::InputExc("unexpected end of file");
        if (n > 0)
            std::memcpy(c, data_ + pos_, (size_t)n);
        pos_ += (uint64_t)n;
        return pos_ < size_;
    }
    uint64_t tellg() override { return pos_; }
    void seekg(uint64_t pos) override { pos_ = pos; }

  private:
    const uint8_t *data_;
    uint64_t size_, pos_;
};

int failed(const char *what, char *msg, size_t cap)
{
    if (cap)
        std::snprintf(msg, cap, "%s", what && *what ? what : "unknown error");
    return ENVL_DWA_FORMAT;
}

} // namespace

struct envl_exr_dwa {
    MemoryStream stream;
    Imf::MultiPartInputFile file;
    Imf::InputPart part;
    envl_exr_dwa(const uint8_t *data, size_t size, const char *name, int p)
        : stream(data, size, name), file(stream, 0), part(file, p)  // 0: decoded on the caller's thread
    {
    }
};

/* Runs f (returning an ENVL_DWA_* code); every exception becomes a code and a message, so
 * none crosses into C. */
template <class F> static int guarded(F f, char *msg, size_t msg_cap)
{
    try {
        return f();
    } catch (const std::bad_alloc &) {
        failed("out of memory", msg, msg_cap);
        return ENVL_DWA_MEMORY;
    } catch (const std::exception &e) {
        return failed(e.what(), msg, msg_cap);
    } catch (...) {
        return failed(nullptr, msg, msg_cap);
    }
}

extern "C" int envl__exr_dwa_open(const uint8_t *data, size_t size, const char *name, int part,
                                  envl_exr_dwa **out, char *msg, size_t msg_cap)
{
    *out = nullptr;
    return guarded(
        [&]() -> int {
            *out = new envl_exr_dwa(data, size, name ? name : "(memory)", part);
            return ENVL_DWA_OK;
        },
        msg, msg_cap);
}

extern "C" int envl__exr_dwa_read(envl_exr_dwa *d, int n, const char *const *names,
                                  float *const *dst, const int32_t *xs, const int32_t *ys,
                                  int32_t y0, int32_t y1, char *msg, size_t msg_cap)
{
    return guarded(
        [&]() -> int {
            const Imath::Box2i &dw = d->part.header().dataWindow();
            int64_t width = (int64_t)dw.max.x - dw.min.x + 1;
            Imf::FrameBuffer fb;
            for (int k = 0; k < n; k++) {
                if (xs[k] <= 0 || ys[k] <= 0)
                    return failed("bad channel sampling", msg, msg_cap);
                // first sampled line of the range: the origin of this channel's rows in dst[k]
                int64_t rem = (int64_t)y0 % ys[k]; // C++: the sign of y0
                int64_t first = rem == 0  ? y0
                                : rem > 0 ? (int64_t)y0 + ys[k] - rem
                                          : (int64_t)y0 - rem;
                Imath::V2i origin(dw.min.x, (int)first);
                size_t row = (size_t)((width + xs[k] - 1) / xs[k]) * sizeof(float);
                fb.insert(names[k], Imf::Slice::Make(Imf::FLOAT, dst[k], origin, width,
                                                     (int64_t)y1 - y0 + 1, sizeof(float), row,
                                                     xs[k], ys[k]));
            }
            d->part.setFrameBuffer(fb);
            d->part.readPixels(y0, y1);
            return ENVL_DWA_OK;
        },
        msg, msg_cap);
}

extern "C" void envl__exr_dwa_close(envl_exr_dwa *d)
{
    try {
        delete d;
    } catch (...) {
    }
}
