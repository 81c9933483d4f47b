// The image back end's implementation over OpenImageIO: the module libtessera_oiio.so
// (renderer/util/image_backend.h says why it is a module). It depends on OpenImageIO and the
// standard library only, so that none of the renderer's state is duplicated in it.
#include <OpenImageIO/imagebuf.h>
#include <OpenImageIO/imagebufalgo.h>
#include <OpenImageIO/imageio.h>
#include <OpenImageIO/texture.h>

#include <memory>
#include <string>
#include <vector>

#include "renderer/util/image_backend.h"

namespace tessera::imageio {
namespace {

OIIO::TypeDesc to_oiio(PixelType t) {
    switch (t) {
        case PixelType::Unknown: return OIIO::TypeDesc::UNKNOWN;
        case PixelType::UInt8: return OIIO::TypeDesc::UINT8;
        case PixelType::Int8: return OIIO::TypeDesc::INT8;
        case PixelType::UInt16: return OIIO::TypeDesc::UINT16;
        case PixelType::Int16: return OIIO::TypeDesc::INT16;
        case PixelType::UInt32: return OIIO::TypeDesc::UINT32;
        case PixelType::Int32: return OIIO::TypeDesc::INT32;
        case PixelType::UInt64: return OIIO::TypeDesc::UINT64;
        case PixelType::Int64: return OIIO::TypeDesc::INT64;
        case PixelType::Half: return OIIO::TypeDesc::HALF;
        case PixelType::Float: return OIIO::TypeDesc::FLOAT;
        case PixelType::Double: return OIIO::TypeDesc::DOUBLE;
    }
    return OIIO::TypeDesc::UNKNOWN;
}

PixelType from_oiio(OIIO::TypeDesc t) {
    switch (OIIO::TypeDesc::BASETYPE(t.basetype)) {
        case OIIO::TypeDesc::UINT8: return PixelType::UInt8;
        case OIIO::TypeDesc::INT8: return PixelType::Int8;
        case OIIO::TypeDesc::UINT16: return PixelType::UInt16;
        case OIIO::TypeDesc::INT16: return PixelType::Int16;
        case OIIO::TypeDesc::UINT32: return PixelType::UInt32;
        case OIIO::TypeDesc::INT32: return PixelType::Int32;
        case OIIO::TypeDesc::UINT64: return PixelType::UInt64;
        case OIIO::TypeDesc::INT64: return PixelType::Int64;
        case OIIO::TypeDesc::HALF: return PixelType::Half;
        case OIIO::TypeDesc::FLOAT: return PixelType::Float;
        case OIIO::TypeDesc::DOUBLE: return PixelType::Double;
        default: return PixelType::Unknown;
    }
}

ImageSpec from_oiio(const OIIO::ImageSpec &s) {
    ImageSpec out;
    out.width = s.width;
    out.height = s.height;
    out.nchannels = s.nchannels;
    out.format = from_oiio(s.format);
    for (const OIIO::TypeDesc &t : s.channelformats) out.channelformats.push_back(from_oiio(t));
    out.channelnames = s.channelnames;
    out.tile_width = s.tile_width;
    for (const OIIO::ParamValue &p : s.extra_attribs) {
        if (p.type() == OIIO::TypeDesc::STRING)
            out.attribute(p.name().string(), p.get_string());
        else if (p.type() == OIIO::TypeDesc::INT)
            out.attribute(p.name().string(), p.get_int());
    }
    return out;
}

OIIO::ImageSpec to_oiio(const ImageSpec &s) {
    OIIO::ImageSpec out(s.width, s.height, s.nchannels, to_oiio(s.format));
    out.channelnames = s.channelnames;
    for (PixelType t : s.channelformats) out.channelformats.push_back(to_oiio(t));
    out.alpha_channel = -1;
    out.z_channel = -1;
    out.tile_width = s.tile_width;
    out.tile_height = s.tile_width;
    for (const Attribute &a : s.attributes) {
        if (a.is_int)
            out.attribute(a.name, a.number);
        else
            out.attribute(a.name, a.text);
    }
    return out;
}

class OiioInput final : public ImageInput {
  public:
    OiioInput(std::unique_ptr<OIIO::ImageInput> in, const OIIO::ImageSpec &spec)
        : in_(std::move(in)) {
        spec_ = from_oiio(spec);
        spec_.format_name = in_->format_name();
        int levels = 1;
        while (in_->seek_subimage(0, levels)) ++levels;
        in_->seek_subimage(0, 0);
        spec_.mip_levels = levels;
    }
    bool read_image(int chbegin, int chend, PixelType type, void *data) override {
        return in_->read_image(0, 0, chbegin, chend, to_oiio(type), data);
    }
    std::string geterror() override { return in_->geterror(); }

  private:
    std::unique_ptr<OIIO::ImageInput> in_;
};

class OiioTextureSystem final : public TextureSystem {
  public:
    explicit OiioTextureSystem(float max_memory_mb) {
        // A private (unshared) system: its cache dies with this object.
        ts_ = OIIO::TextureSystem::create(false);
        ts_->attribute("max_memory_MB", max_memory_mb);
    }
    ~OiioTextureSystem() override { OIIO::TextureSystem::destroy(ts_); }
    void *handle(const std::string &path, int *nchannels, std::string *error) override {
        OIIO::TextureSystem::TextureHandle *h = ts_->get_texture_handle(OIIO::ustring(path));
        OIIO::ImageSpec spec;
        if (!h || !ts_->get_imagespec(h, nullptr, 0, spec)) {
            *error = ts_->geterror();
            return nullptr;
        }
        *nchannels = spec.nchannels;
        return h;
    }
    bool texture(void *handle, const TextureOptions &opt, float s, float t, float dsdx,
                 float dtdx, float dsdy, float dtdy, int nchannels, float *out) const override {
        OIIO::TextureOpt o;
        const auto wrap = [](TextureOptions::Wrap w) {
            return w == TextureOptions::Wrap::Periodic ? OIIO::TextureOpt::WrapPeriodic
                   : w == TextureOptions::Wrap::Black  ? OIIO::TextureOpt::WrapBlack
                                                       : OIIO::TextureOpt::WrapClamp;
        };
        o.swrap = wrap(opt.swrap);
        o.twrap = wrap(opt.twrap);
        o.mipmode = opt.mip == TextureOptions::Mip::Trilinear ? OIIO::TextureOpt::MipModeTrilinear
                    : opt.mip == TextureOptions::Mip::Aniso   ? OIIO::TextureOpt::MipModeAniso
                                                              : OIIO::TextureOpt::MipModeOneLevel;
        o.interpmode = opt.interp == TextureOptions::Interp::Closest
                           ? OIIO::TextureOpt::InterpClosest
                           : OIIO::TextureOpt::InterpBilinear;
        o.anisotropic = opt.anisotropic;
        return ts_->texture(static_cast<OIIO::TextureSystem::TextureHandle *>(handle), nullptr, o,
                            s, t, dsdx, dtdx, dsdy, dtdy, nchannels, out);
    }

  private:
    OIIO::TextureSystem *ts_ = nullptr;
};

class OiioBackend final : public Backend {
  public:
    std::unique_ptr<ImageInput> open(const std::string &path, bool unassociated_alpha,
                                     std::string *error) const override {
        OIIO::ImageSpec config;
        if (unassociated_alpha) config.attribute("oiio:UnassociatedAlpha", 1);
        auto in = OIIO::ImageInput::open(path, &config);
        if (!in) {
            *error = OIIO::geterror();
            return nullptr;
        }
        const OIIO::ImageSpec spec = in->spec();
        return std::make_unique<OiioInput>(std::move(in), spec);
    }

    bool write(const std::string &format, const std::string &file, const ImageSpec &spec,
               PixelType data_type, const void *data, std::string *error) const override {
        auto out = OIIO::ImageOutput::create(format);
        if (!out) {
            *error = "no image writer: " + OIIO::geterror();
            return false;
        }
        if (!out->open(file, to_oiio(spec))) {
            *error = "cannot open for writing: " + out->geterror();
            return false;
        }
        if (!out->write_image(to_oiio(data_type), data)) {
            *error = "write failed: " + out->geterror();
            out->close();
            return false;
        }
        if (!out->close()) {
            *error = "close failed: " + out->geterror();
            return false;
        }
        return true;
    }

    bool make_texture(const std::string &file, int width, int height, int nchannels,
                      const float *pixels, PixelType stored, std::string *error) const override {
        OIIO::ImageSpec spec(width, height, nchannels, OIIO::TypeDesc::FLOAT);
        spec.alpha_channel = -1;
        spec.z_channel = -1;
        OIIO::ImageBuf lin(spec);
        lin.set_pixels(lin.roi(), OIIO::TypeDesc::FLOAT, pixels);
        OIIO::ImageSpec config;
        config.tile_width = 64;
        config.tile_height = 64;
        config.tile_depth = 1;
        config.set_format(to_oiio(stored));
        config.attribute("maketx:filtername", "box");
        if (!OIIO::ImageBufAlgo::make_texture(OIIO::ImageBufAlgo::MakeTxTexture, lin, file,
                                              config)) {
            *error = OIIO::geterror();
            return false;
        }
        return true;
    }

    std::unique_ptr<TextureSystem> texture_system(float max_memory_mb) const override {
        return std::make_unique<OiioTextureSystem>(max_memory_mb);
    }
};

}  // namespace

}  // namespace tessera::imageio

extern "C" __attribute__((visibility("default"))) const tessera::imageio::Backend *
tessera_image_backend_v1() {
    static const tessera::imageio::OiioBackend backend;
    return &backend;
}
