// Uses the installed vbme package: fits a disk to a drawn circle and checks the answer.
#include <cstdio>

#include <opencv2/vbme/track.hpp>

int main() {
    const cv::vbme::Disk truth(cv::Point2f(40.f, 30.f), 12.f);
    cv::Mat mask;
    cv::vbme::diskMask(cv::Size(80, 60), truth, mask);
    const cv::vbme::Disk d = cv::vbme::fitDisk(mask);
    const double err = cv::norm(d.center - truth.center) + std::abs(d.radius - truth.radius);
    std::printf("vbme %s consumer: fitted (%.2f, %.2f) r %.2f, error %.3f\n", VBME_VERSION, d.center.x,
                d.center.y, d.radius, err);
    return err < 0.5 ? 0 : 1;
}
