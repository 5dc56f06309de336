// Uses the installed vbme package: fits a disk to a drawn circle and checks the answer, and
// checks the material edit's settings through the pipeline module (the top of the dependency chain,
// so every module's installed headers and libraries are exercised).
#include <cstdio>

#include <opencv2/vbme/pipeline.hpp>
#include <opencv2/vbme/track.hpp>

int main() {
    const cv::vbme::Disk truth(cv::Point2f(40.f, 30.f), 12.f);
    cv::Mat mask;
    cv::vbme::diskMask(cv::Size(80, 60), truth, mask);
    const cv::vbme::Disk d = cv::vbme::fitDisk(mask);
    const double err = cv::norm(d.center - truth.center) + std::abs(d.radius - truth.radius);
    cv::vbme::MaterialEditParams params;
    params.material = cv::vbme::Material::preset("chrome");
    params.check();
    const cv::vbme::Material& chrome = params.material;
    std::printf("vbme %s consumer: fitted (%.2f, %.2f) r %.2f, error %.3f; chrome is %s\n",
                VBME_VERSION, d.center.x, d.center.y, d.radius, err,
                cv::vbme::Material::typeName(chrome.type).c_str());
    return err < 0.5 && chrome.type == cv::vbme::Material::CONDUCTOR ? 0 : 1;
}
