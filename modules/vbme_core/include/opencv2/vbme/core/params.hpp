// This file is part of vbme, licensed under the Apache License 2.0 (see LICENSE).
#ifndef OPENCV_VBME_CORE_PARAMS_HPP
#define OPENCV_VBME_CORE_PARAMS_HPP

#include <algorithm>
#include <cmath>
#include <initializer_list>
#include <iterator>
#include <limits>
#include <string>
#include <type_traits>
#include <utility>
#include <vector>

#include <opencv2/core.hpp>

#include "opencv2/vbme/core/utility.hpp"

namespace cv {
namespace vbme {

//! @addtogroup vbme_core
//! @{

/** @brief Reads the fields of a params struct from a FileStorage map, checking each value's
type, and refuses keys it does not know.

Every `*Params` / `*Options` struct's `read(const FileNode&)` names its fields through this
reader. The keys are kept by a ParamsReader (utility.hpp), whose finish() throws a
cv::Exception listing the keys of the map that no field took, and the valid keys, so that a
misspelt setting is an error instead of being silently ignored. Unlike ParamsReader's plain
conversions, a value of the wrong type is an error naming the field (a word where a number
belongs, a fraction or an out-of-range number for an integer, 2 for a boolean).
A missing key keeps the field's current value. An empty or none node reads nothing.

Types: `bool` (0/1 or true/false), integers and enums (numbers, checked to be whole and in
the type's range), `float`/`double`, `std::string`, `Size` (`[w, h]`), `Vec` and `Matx` (a flat list
of numbers, row by row) and any struct with a `read(const FileNode&)` member (a nested map). Fields
stored another way (e.g. an enum as a name) are read with take(), which marks the key as known and
returns its node.

@code
void MyParams::read(const FileNode& fn) {
    ParamsIn in(fn, "my params");
    in("radius", radius);
    if (FileNode n = in.take("mode"); !n.empty()) mode = parseMode((std::string)n);
    in.finish();
}
@endcode
*/
class CV_EXPORTS ParamsIn {
public:
    /** @brief Starts reading @p node; @p what names the struct in error messages. Throws when
    the node is neither a map nor empty. */
    ParamsIn(const FileNode& node, const char* what);

    /** @brief Reads @p key into @p v when present; returns whether it was present. */
    template <class T>
    bool operator()(const char* key, T& v) {
        const FileNode n = take(key);
        if (n.empty() || n.isNone()) return false;
        assign(key, n, v);
        return true;
    }

    /** @brief Reads @p key, a name, into @p v: the value paired with that name in @p names
    (compared without case); an unknown name is an error listing the valid ones. Returns
    whether the key was present. */
    template <class T>
    bool choice(const char* key, T& v, std::initializer_list<std::pair<const char*, T>> names) {
        const FileNode n = take(key);
        if (n.empty() || n.isNone()) return false;
        std::vector<std::string> valid;
        for (const auto& kv : names)
            valid.emplace_back(kv.first);
        v = std::next(names.begin(), pickName(key, n, valid))->second;
        return true;
    }

    /** @brief Marks @p key as known and returns its node (empty when absent). */
    FileNode take(const char* key);

    /** @brief Throws naming the keys of the map that were not taken, and the valid keys. */
    void finish() const { keys_.finish(); }

    /** @brief The struct's name given to the constructor. */
    const std::string& what() const { return keys_.what(); }

private:
    template <class T>
    using has_read = decltype(std::declval<T&>().read(std::declval<const FileNode&>()));
    template <class T, class = void>
    struct is_readable : std::false_type {};
    template <class T>
    struct is_readable<T, std::void_t<has_read<T>>> : std::true_type {};

    template <class T>
    struct is_matx : std::false_type {};
    template <class T, int m, int n>
    struct is_matx<Matx<T, m, n>> : std::true_type {};
    template <class T, int n>
    struct is_matx<Vec<T, n>> : std::true_type {};

    template <class T>
    void assign(const char* key, const FileNode& n, T& v) {
        if constexpr (std::is_same<T, bool>::value) {
            v = readBool(key, n);
        } else if constexpr (std::is_enum<T>::value) {
            v = static_cast<T>(readNumber(key, n, true, -2147483648.0, 2147483647.0));
        } else if constexpr (std::is_integral<T>::value) {
            const double lo =
                std::is_signed<T>::value ? (double)std::numeric_limits<T>::lowest() : 0.0;
            // the largest double that converts into T without overflow
            const double hi = std::numeric_limits<T>::digits > 53
                                  ? std::nextafter((double)std::numeric_limits<T>::max(), 0.0)
                                  : (double)std::numeric_limits<T>::max();
            v = static_cast<T>(readNumber(key, n, true, lo, hi));
        } else if constexpr (std::is_floating_point<T>::value) {
            v = static_cast<T>(readNumber(key, n, false, -HUGE_VAL, HUGE_VAL));
        } else if constexpr (std::is_same<T, std::string>::value) {
            v = readString(key, n);
        } else if constexpr (std::is_same<T, Size>::value) {
            const std::vector<double> s = readNumbers(key, n, 2, true);
            v = Size((int)s[0], (int)s[1]);
        } else if constexpr (is_matx<T>::value) {
            const std::vector<double> s = readNumbers(
                key, n, T::rows * T::cols, std::is_integral<typename T::value_type>::value);
            for (int i = 0; i < T::rows * T::cols; ++i)
                v.val[i] = (typename T::value_type)s[i];
        } else {
            static_assert(is_readable<T>::value, "ParamsIn: no reader for this field type");
            v.read(n);
        }
    }

    bool readBool(const char* key, const FileNode& n) const;
    size_t pickName(const char* key, const FileNode& n,
                    const std::vector<std::string>& valid) const;
    double readNumber(const char* key, const FileNode& n, bool whole, double lo, double hi) const;
    std::string readString(const char* key, const FileNode& n) const;
    std::vector<double> readNumbers(const char* key, const FileNode& n, int count,
                                    bool whole) const;

    ParamsReader keys_;
};

/** @brief Throws a cv::Exception (StsBadArg) saying "<what>.<field> = <value>: expected
<expected>" when @p ok is false; the check() of every params struct is written with it. */
CV_EXPORTS void checkParam(bool ok, const char* what, const char* field, double value,
                           const char* expected);

//! @}

}  // namespace vbme
}  // namespace cv

#endif
