// Materials end to end: thin dielectric panes, coated conductors, pbrt-v4 parameter names of
// the approximated materials.
#include <doctest/doctest.h>

#include <sstream>

#include "approx.h"
#include "render_test_util.h"
#include "renderer/input/scene_desc.h"
#include "renderer/integrators/whitted_integrator.h"
#include "test_helpers.h"

#include <OpenImageIO/imageio.h>
#include <cstdio>

using namespace tessera;
using namespace tessera::test;

namespace {

/// A camera looking through a pane (material `mat`) at an emitter of radiance 1.
std::string pane_scene(const std::string &mat, int depth) {
    std::ostringstream os;
    os << "LookAt 0 0 -3  0 0 0  0 1 0\nCamera \"perspective\" \"float fov\" [ 10 ]\n"
       << "Film \"rgb\" \"integer xresolution\" [ 4 ] \"integer yresolution\" [ 4 ]\n"
       << "Sampler \"zsobol\" \"integer pixelsamples\" [ 256 ]\nPixelFilter \"box\"\n"
       << "Integrator \"path\" \"integer maxdepth\" [ " << depth << " ]\nWorldBegin\n"
       << "AttributeBegin\nAreaLightSource \"diffuse\" \"rgb L\" [ 1 1 1 ]\n"
       << "Shape \"trianglemesh\" \"point3 P\" [ -9 -9 2  9 -9 2  9 9 2  -9 9 2 ]\n"
       << "  \"integer indices\" [ 0 2 1  0 3 2 ]\nAttributeEnd\n"
       << mat << "\nShape \"trianglemesh\" \"point3 P\" [ -9 -9 0  9 -9 0  9 9 0  -9 9 0 ]\n"
       << "  \"integer indices\" [ 0 1 2  0 2 3 ]\n";
    return os.str();
}

}  // namespace

TEST_CASE("thindielectric: a pane transmits 1 - R' with R' = R + T^2 R / (1 - R^2)") {
    auto sc = scene_from_string(pane_scene("Material \"thindielectric\" \"float eta\" [ 1.5 ]", 2));
    double R = 0.04, T = 0.96;  // normal incidence, eta 1.5 (the fov is narrow)
    double Rp = R + T * T * R / (1 - R * R);
    double g = image_mean(render_image(*sc), 1);
    CHECK(g == test::Approx(1 - Rp).epsilon(0.01));
    // A refracting dielectric slab of one surface would instead scale radiance by eta^2 inside.
}

TEST_CASE("coatedconductor reads pbrt-v4's parameters; a clear coat over a mirror loses nothing") {
    int before = warning_count();
    auto sc = scene_from_string(
        pane_scene("Material \"coatedconductor\" \"spectrum conductor.eta\" \"metal-Ag-eta\" "
                   "\"spectrum conductor.k\" \"metal-Ag-k\" \"float conductor.roughness\" [ 0.1 ] "
                   "\"float interface.roughness\" [ 0 ] \"float thickness\" [ 0.01 ] "
                   "\"float interface.eta\" [ 1.4 ] \"rgb albedo\" [ 0 0 0 ] \"float g\" [ 0 ] "
                   "\"integer maxdepth\" [ 10 ] \"integer nsamples\" [ 1 ]",
                   1));
    // Every parameter is pbrt-v4's and used: no warning at all.
    CHECK(warning_count() == before);
    // A plane filling the view under a white sky, one bounce: a smooth coat over a smooth
    // mirror returns all of it (F + T^2 / (1 - F) = 1); a thick absorbing layer does not.
    auto furnace = [](const std::string &mat) {
        std::ostringstream os;
        os << "LookAt 0 0 -3  0 0 0  0 1 0\nCamera \"perspective\" \"float fov\" [ 20 ]\n"
           << "Film \"rgb\" \"integer xresolution\" [ 4 ] \"integer yresolution\" [ 4 ]\n"
           << "Sampler \"zsobol\" \"integer pixelsamples\" [ 16 ]\nPixelFilter \"box\"\n"
           << "Integrator \"path\" \"integer maxdepth\" [ 1 ]\nWorldBegin\n"
           << "LightSource \"infinite\" \"rgb L\" [ 1 1 1 ]\n"
           << mat << "\nShape \"trianglemesh\" \"point3 P\" [ -9 -9 0  9 -9 0  9 9 0  -9 9 0 ]\n"
           << "  \"integer indices\" [ 0 1 2  0 2 3 ]\n";
        return image_mean(render_image(*scene_from_string(os.str())), 1);
    };
    CHECK(furnace("Material \"coatedconductor\" \"rgb reflectance\" [ 1 1 1 ] "
                  "\"float thickness\" [ 0 ]") == test::Approx(1.0).epsilon(2e-3));
    // The Whitted integrator treats both layers as mirrors: the same 1.
    {
        std::ostringstream os;
        os << "LookAt 0 0 -3  0 0 0  0 1 0\nCamera \"perspective\" \"float fov\" [ 20 ]\n"
           << "Film \"rgb\" \"integer xresolution\" [ 4 ] \"integer yresolution\" [ 4 ]\n"
           << "WorldBegin\nLightSource \"infinite\" \"rgb L\" [ 1 1 1 ]\n"
           << "Material \"coatedconductor\" \"rgb reflectance\" [ 1 1 1 ] \"float thickness\" 0 "
           << "\"float conductor.roughness\" 0.3\n"
           << "Shape \"trianglemesh\" \"point3 P\" [ -9 -9 0  9 -9 0  9 9 0  -9 9 0 ]\n"
           << "  \"integer indices\" [ 0 1 2  0 2 3 ]\n";
        auto wsc = scene_from_string(os.str());
        WhittedIntegrator w(*wsc);
        CameraSample cs;
        cs.px = 2;
        cs.py = 2;
        cs.fx = cs.fy = 0.5f;
        CHECK(w.evaluate(cs).radiance.g == test::Approx(1.0).epsilon(2e-3));
    }
    double thick = furnace(
        "Material \"coatedconductor\" \"rgb reflectance\" [ 1 1 1 ] "
        "\"float thickness\" [ 0.5 ]");
    CHECK(thick < 0.5);
    CHECK(thick > 0.2);
    // Without a coat (interface.eta 1) it is the conductor itself.
    CHECK(furnace("Material \"coatedconductor\" \"float interface.eta\" [ 1 ] "
                  "\"float thickness\" [ 0 ] \"rgb reflectance\" [ 0.6 0.6 0.6 ]") ==
          test::Approx(furnace("Material \"conductor\" \"rgb reflectance\" [ 0.6 0.6 0.6 ]"))
              .epsilon(1e-3));
}

TEST_CASE("diffusetransmission: a sheet under a white sky reflects r and transmits t") {
    // A plane filling the view, the sky on both sides, one bounce: r + t of the sky arrives.
    std::string s =
        "LookAt 0 0 -3  0 0 0  0 1 0\nCamera \"perspective\" \"float fov\" [ 20 ]\n"
        "Film \"rgb\" \"integer xresolution\" [ 4 ] \"integer yresolution\" [ 4 ]\n"
        "Sampler \"zsobol\" \"integer pixelsamples\" [ 256 ]\nPixelFilter \"box\"\n"
        "Integrator \"path\" \"integer maxdepth\" [ 1 ]\nWorldBegin\n"
        "LightSource \"infinite\" \"rgb L\" [ 1 1 1 ]\n"
        "Material \"diffusetransmission\" \"rgb reflectance\" [ 0.3 0.1 0.6 ] "
        "\"rgb transmittance\" [ 0.5 0.2 0.2 ]\n"
        "Shape \"trianglemesh\" \"point3 P\" [ -9 -9 0  9 -9 0  9 9 0  -9 9 0 ]\n"
        "  \"integer indices\" [ 0 1 2  0 2 3 ]\n";
    int before = warning_count();
    sampling::RgbImage img = render_image(*scene_from_string(s));
    CHECK(warning_count() == before);
    CHECK(image_mean(img, 0) == test::Approx(0.8).epsilon(0.01));
    CHECK(image_mean(img, 1) == test::Approx(0.3).epsilon(0.01));
    CHECK(image_mean(img, 2) == test::Approx(0.8).epsilon(0.01));
}

TEST_CASE("diffusetransmission keeps pbrt-v4's reflectance default 0.25") {
    std::string s =
        "LookAt 0 0 5  0 0 0  0 1 0\nCamera \"perspective\" \"float fov\" [ 10 ]\n"
        "Film \"rgb\" \"integer xresolution\" [ 4 ] \"integer yresolution\" [ 4 ]\n"
        "Sampler \"zsobol\" \"integer pixelsamples\" [ 64 ]\nPixelFilter \"box\"\n"
        "Integrator \"path\" \"integer maxdepth\" [ 1 ]\nWorldBegin\n"
        "LightSource \"infinite\" \"rgb L\" [ 1 1 1 ]\n"
        "Material \"diffusetransmission\"\nShape \"sphere\" \"float radius\" [ 1 ]\n";
    auto sc = scene_from_string(s);
    // Albedo 0.25 under a white environment, one bounce: 0.25 everywhere on the sphere (what it
    // transmits goes into the closed sphere, which the sky does not reach).
    CHECK(image_mean(render_image(*sc), 0) == test::Approx(0.25).epsilon(0.01));
    // "scale" multiplies a given reflectance too, then clamps to 1 (pbrt-v4):
    // 0.2 x 2 = 0.4 in red, 0.8 x 2 = 1.6 -> 1 in blue.
    auto scaled = [&](const std::string &params) {
        std::string t = s;
        t.replace(t.find("\"diffusetransmission\""), 21, "\"diffusetransmission\" " + params);
        return render_image(*scene_from_string(t));
    };
    sampling::RgbImage img = scaled("\"rgb reflectance\" [ 0.2 0.4 0.8 ] \"float scale\" [ 2 ]");
    CHECK(image_mean(img, 0) == test::Approx(0.4).epsilon(0.01));
    CHECK(image_mean(img, 1) == test::Approx(0.8).epsilon(0.01));
    CHECK(image_mean(img, 2) == test::Approx(1.0).epsilon(0.01));
    CHECK(image_mean(scaled("\"float scale\" [ 0.5 ]"), 0) == test::Approx(0.125).epsilon(0.01));
}

TEST_CASE("bump mapping: a displacement ramp tilts the shading normal by atan(slope)") {
    // A unit-reflectance quad lit head-on by a distant light of irradiance pi: radiance is the
    // cosine between the (bumped) shading normal and the light. displacement = S * u over a
    // quad 2 units wide has slope S / 2: S = 2 tilts the normal by 45 degrees.
    auto make = [](const std::string &material) {
        return "LookAt 0 0 -3  0 0 0  0 1 0\nCamera \"perspective\" \"float fov\" [ 20 ]\n"
               "Film \"rgb\" \"integer xresolution\" [ 4 ] \"integer yresolution\" [ 4 ]\n"
               "Sampler \"zsobol\" \"integer pixelsamples\" [ 4 ]\nPixelFilter \"box\"\n"
               "Integrator \"path\" \"integer maxdepth\" [ 1 ]\nWorldBegin\n"
               "LightSource \"distant\" \"rgb L\" [ 3.14159265 3.14159265 3.14159265 ]\n"
               "  \"point3 from\" [ 0 0 -1 ] \"point3 to\" [ 0 0 0 ]\n"
               "Texture \"ramp\" \"float\" \"bilerp\" \"float v00\" [ 0 ] \"float v10\" [ 2 ]\n"
               "  \"float v01\" [ 0 ] \"float v11\" [ 2 ]\n" +
               material +
               "\nShape \"trianglemesh\" \"point3 P\" [ -1 -1 0  1 -1 0  1 1 0  -1 1 0 ]\n"
               "  \"point2 uv\" [ 0 0  1 0  1 1  0 1 ] \"integer indices\" [ 0 1 2  0 2 3 ]\n";
    };
    auto flat = scene_from_string(make("Material \"diffuse\" \"rgb reflectance\" [ 1 1 1 ]"));
    CHECK(image_mean(render_image(*flat), 1) == test::Approx(1.0).epsilon(0.002));
    auto bumped = scene_from_string(make("Material \"diffuse\" \"rgb reflectance\" [ 1 1 1 ] "
                                         "\"texture displacement\" \"ramp\""));
    CHECK(image_mean(render_image(*bumped), 1) == test::Approx(std::sqrt(0.5)).epsilon(0.01));
}

TEST_CASE("normal map: a constant tangent-space normal tilted by 45 degrees") {
    // pbrt-v4 NormalMap: texel (r, g, b) = (n + 1) / 2 in the frame of dpdu and the normal.
    std::string dir = test::output_dir();
    std::string file = dir + "/normalmap45.exr";
    {
        float s = std::sqrt(0.5f);
        float texel[3] = {(s + 1) / 2, 0.5f, (s + 1) / 2};
        auto out = OIIO::ImageOutput::create(file);
        REQUIRE(out);
        OIIO::ImageSpec spec(1, 1, 3, OIIO::TypeDesc::FLOAT);
        REQUIRE(out->open(file, spec));
        REQUIRE(out->write_image(OIIO::TypeDesc::FLOAT, texel));
        out->close();
    }
    std::string scene =
        "LookAt 0 0 -3  0 0 0  0 1 0\nCamera \"perspective\" \"float fov\" [ 20 ]\n"
        "Film \"rgb\" \"integer xresolution\" [ 4 ] \"integer yresolution\" [ 4 ]\n"
        "Sampler \"zsobol\" \"integer pixelsamples\" [ 4 ]\nPixelFilter \"box\"\n"
        "Integrator \"path\" \"integer maxdepth\" [ 1 ]\nWorldBegin\n"
        "LightSource \"distant\" \"rgb L\" [ 3.14159265 3.14159265 3.14159265 ]\n"
        "  \"point3 from\" [ 0 0 -1 ] \"point3 to\" [ 0 0 0 ]\n"
        "Material \"diffuse\" \"rgb reflectance\" [ 1 1 1 ] \"string normalmap\" \"" +
        file +
        "\"\nShape \"trianglemesh\" \"point3 P\" [ -1 -1 0  1 -1 0  1 1 0  -1 1 0 ]\n"
        "  \"point2 uv\" [ 0 0  1 0  1 1  0 1 ] \"integer indices\" [ 0 1 2  0 2 3 ]\n";
    auto sc = scene_from_string(scene);
    CHECK(image_mean(render_image(*sc), 1) == test::Approx(std::sqrt(0.5)).epsilon(0.01));
    std::remove(file.c_str());
}
