#include "orbcal/render/degrade.hpp"

#include <cmath>
#include <opencv2/imgproc.hpp>
#include <stdexcept>

namespace orbcal::render {

void gaussianBlur(cv::Mat& img, double sigma_px) {
  if (!(sigma_px > 0)) return;
  const int half = static_cast<int>(std::ceil(4.0 * sigma_px));
  cv::GaussianBlur(img, img, cv::Size(2 * half + 1, 2 * half + 1), sigma_px, sigma_px, cv::BORDER_REPLICATE);
}

cv::Mat applyDegradations(const cv::Mat& clean, const Degradations& d, std::mt19937_64& rng) {
  if (clean.type() != CV_8UC1) throw std::invalid_argument("applyDegradations: expected a CV_8UC1 image");
  const bool blur = d.defocus_sigma_px > 0, shot = d.full_well_e > 0, read = d.read_noise_dn > 0;
  if (!blur && !shot && !read) return clean;
  cv::Mat img;
  clean.convertTo(img, CV_32FC1);
  gaussianBlur(img, d.defocus_sigma_px);
  if (shot || read) {
    std::normal_distribution<float> n01(0.f, 1.f);
    const float e_per_dn = static_cast<float>(d.full_well_e / 255.0);
    const float read_dn = static_cast<float>(d.read_noise_dn);
    for (int r = 0; r < img.rows; ++r) {
      float* p = img.ptr<float>(r);
      for (int c = 0; c < img.cols; ++c) {
        float v = p[c];
        if (shot) {
          const float e = std::max(0.f, v * e_per_dn);
          v = (e + std::sqrt(e) * n01(rng)) / e_per_dn;
        }
        if (read) v += read_dn * n01(rng);
        p[c] = v;
      }
    }
  }
  cv::Mat out;
  img.convertTo(out, CV_8UC1);  // rounds and saturates
  return out;
}

}  // namespace orbcal::render
