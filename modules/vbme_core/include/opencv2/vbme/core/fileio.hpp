// This file is part of vbme, licensed under the Apache License 2.0 (see LICENSE).
#ifndef OPENCV_VBME_CORE_FILEIO_HPP
#define OPENCV_VBME_CORE_FILEIO_HPP

#include <string>
#include <vector>

#include <opencv2/core.hpp>

namespace cv {
namespace vbme {

//! @addtogroup vbme_core
//! @{

/** @brief A file written under a temporary name in its final folder and renamed to its final
name by commit(), so that readers never see a half-written output.

The temporary name keeps the extension (encoders choose the format by it). If the object is
destroyed without commit() (an error, an exception), the temporary file is removed.
*/
class CV_EXPORTS AtomicFile {
public:
    /** @brief Prepares to write @p final_path (its folder is created if missing). */
    explicit AtomicFile(const std::string& final_path);
    ~AtomicFile();
    AtomicFile(const AtomicFile&) = delete;
    AtomicFile& operator=(const AtomicFile&) = delete;

    /** @brief The name to write to. */
    const std::string& tempPath() const { return temp_; }
    /** @brief The name it will have. */
    const std::string& finalPath() const { return final_; }
    /** @brief Renames the temporary file to the final name. Throws if it does not exist. */
    void commit();

private:
    std::string final_, temp_;
    bool committed_ = false;
};

/** @brief Throws cv::Exception if @p path exists and @p force is false ("exists; use --force
to overwrite"). */
CV_EXPORTS void checkOverwrite(const std::string& path, bool force);

/** @brief Writes an image through AtomicFile; throws cv::Exception if encoding fails. */
CV_EXPORTS void imwriteAtomic(const std::string& path, InputArray img,
                              const std::vector<int>& params = std::vector<int>());

/** @brief Reads an image, throwing cv::Exception saying whether it is missing or
undecodable. @p flags as for cv::imread. */
CV_EXPORTS Mat imreadChecked(const std::string& path, int flags = 1 /* cv::IMREAD_COLOR */);

/** @brief Reads an object mask (8-bit, 255 = object; any non-zero pixel counts) such as the
first-frame mask of `vbme track` and `vbme material-edit`. Throws cv::Exception naming the file
when it is missing or undecodable, when its size is not @p expected_size (unless that is empty),
or when it marks no pixel or every pixel. @return the mask as CV_8U, 0 or 255. */
CV_EXPORTS Mat readObjectMask(const std::string& path, Size expected_size = Size());

/** @brief Opens a YAML or JSON file with cv::FileStorage for reading. Throws cv::Exception
"<path>: not a readable YAML/JSON file: <parser's reason>" (StsParseError) when it cannot be
parsed and "<path>: cannot open <what>" (StsError) when it cannot be opened; @p what names the
file's role, e.g. "scene file". */
CV_EXPORTS FileStorage openForReading(const std::string& path, const std::string& what);

/** @brief Opens the temporary file of @p out with cv::FileStorage for writing (YAML or JSON by
the final name's extension); throws cv::Exception "<final path>: cannot open for writing" when
it cannot. */
CV_EXPORTS FileStorage openForWriting(const AtomicFile& out);

/** @brief Writes `key: [ {…}, {…}, … ]` with cv::FileStorage: one map per element of @p items,
its fields written by @p write_one(item) between the braces. Writes nothing when @p items is
empty (readers treat a missing key as an empty list). */
template <typename Seq, typename WriteOne>
void writeMapSeq(FileStorage& fs, const std::string& key, const Seq& items, WriteOne write_one) {
    if (items.empty()) return;
    fs << key << "[";
    for (const auto& item : items) {
        fs << "{";
        write_one(item);
        fs << "}";
    }
    fs << "]";
}

/** @brief @p p if absolute, else @p p relative to folder @p base, normalised. */
CV_EXPORTS std::string resolvePath(const std::string& base, const std::string& p);
/** @brief @p p relative to folder @p base if it lies below it, else @p p unchanged. */
CV_EXPORTS std::string relativePath(const std::string& base, const std::string& p);
/** @brief Folder of a file path ("." for a bare name). */
CV_EXPORTS std::string parentFolder(const std::string& path);

/** @brief File name of a per-frame mask: `mask_%05d.png` (DESIGN, "Per-frame masks"). */
CV_EXPORTS std::string maskFileName(int frame);

//! @}

}  // namespace vbme
}  // namespace cv

#endif
