// `tessera diff`: image metrics of two files.
#include "renderer/app/diff.h"

#include <cstdio>
#include <exception>

#include "renderer/util/image_io.h"
#include "sampling/image_metrics.h"

namespace tessera {

namespace {

// A metric row: name, R, G, B, total, in a fixed-width layout that scripts can split on spaces.
void print_row(std::ostream &out, const char *name, const sampling::ChannelMetric &m) {
    char buf[200];
    std::snprintf(buf, sizeof buf, "%-11s %14.6g %14.6g %14.6g %14.6g\n", name, m.channel[0],
                  m.channel[1], m.channel[2], m.total);
    out << buf;
}

void print_mean(std::ostream &out, const char *name, const std::array<double, 3> &m) {
    char buf[200];
    std::snprintf(buf, sizeof buf, "%-11s %14.6g %14.6g %14.6g %14.6g\n", name, m[0], m[1], m[2],
                  (m[0] + m[1] + m[2]) / 3.0);
    out << buf;
}

}  // namespace

int run_diff(const std::string &a, const std::string &b, std::ostream &out, std::ostream &err) {
    sampling::RgbImage img_a, img_b;
    try {
        img_a = read_image_rgb(a);
        img_b = read_image_rgb(b);
    } catch (const std::exception &e) {
        err << "diff: " << e.what() << "\n";
        return 2;
    }
    if (img_a.width != img_b.width || img_a.height != img_b.height) {
        err << "diff: image sizes differ: " << a << " is " << img_a.width << "x"
            << img_a.height << ", " << b << " is " << img_b.width << "x" << img_b.height
            << "\n";
        return 2;
    }
    sampling::ImageComparison c = sampling::compare_images(img_a, img_b, 1.0);
    out << "A: " << a << "\nB: " << b << " (reference)\n"
        << "size: " << img_a.width << "x" << img_a.height << "\n";
    char header[200];
    std::snprintf(header, sizeof header, "%-11s %14s %14s %14s %14s\n", "metric", "R", "G", "B",
                  "total");
    out << header;
    print_row(out, "MSE", c.mse);
    print_row(out, "RMSE", c.rmse);
    print_row(out, "relMSE", c.rel_mse);
    // relMSE without the 0.1% of pixels of largest error (sampling/image_metrics.h): the
    // figure that fireflies do not decide.
    print_row(out, "relMSE-0.1%", c.rel_mse_robust);
    print_row(out, "PSNR", c.psnr);
    print_row(out, "MAE", c.mae);
    print_mean(out, "mean(A)", c.mean_test);
    print_mean(out, "mean(B)", c.mean_ref);
    return 0;
}

}  // namespace tessera
