// `tessera diff A B`: error metrics of image A against image B (the reference).
#pragma once

#include <ostream>
#include <string>

namespace tessera {

/// Reads the RGB of images `a` (test) and `b` (reference) with read_image_rgb and prints, per
/// channel and in total, MSE, RMSE, relMSE ((a-b)^2 / (b^2 + 0.01)), PSNR (peak 1) and MAE,
/// and the mean per channel of each image, to `out`. Returns 0 on success, 2 (after a one-line
/// message on `err`) when an image cannot be read or the sizes differ. Thread-safe.
int run_diff(const std::string &a, const std::string &b, std::ostream &out, std::ostream &err);

}  // namespace tessera
