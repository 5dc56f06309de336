// This file is part of vbme, licensed under the Apache License 2.0 (see LICENSE).
// vbme annotate: the local web server behind the annotation page. The request handling is a
// plain function of (method, path, headers, body) so that tests call the API without a
// network or a browser; AnnotateServer puts it behind cpp-httplib on 127.0.0.1.
#ifndef VBME_APP_ANNOTATE_SERVER_HPP
#define VBME_APP_ANNOTATE_SERVER_HPP

#include <map>
#include <memory>
#include <mutex>
#include <string>
#include <vector>

#include <opencv2/core.hpp>
#include <opencv2/vbme/calib.hpp>

namespace vbme_app {

/** @brief What `vbme annotate` was asked to do. */
struct AnnotateConfig {
    std::string video;       //!< video file, image folder or pattern (for messages)
    std::string annotation;  //!< annotation to reopen (empty: start blank)
    std::string out;         //!< annotation file written by save
    std::string scene_out;   //!< scene file written by save (empty: none)
    std::string object;      //!< mesh placed and previewed on the page (empty: none)
    int frame = 0;           //!< frame shown first
    /** @brief Largest request body accepted (bytes); larger ones get 413. */
    size_t max_body = 1 << 20;
};

/** @brief A request as the server sees it (header names lower-case). */
struct AnnotateRequest {
    std::string method;                          //!< GET, POST, …
    std::string path;                            //!< path without the query
    std::map<std::string, std::string> query;    //!< query parameters
    std::map<std::string, std::string> headers;  //!< lower-case name → value
    std::string body;                            //!< request body
};

/** @brief The reply: status, content type and body. */
struct AnnotateReply {
    int status = 200;          //!< HTTP status
    std::string content_type;  //!< MIME type
    std::string body;          //!< body bytes
};

/** @brief One embedded page asset. */
struct EmbeddedAsset {
    const char* name;           //!< file name ("index.html", "app.js", …)
    const char* content_type;   //!< MIME type
    const unsigned char* data;  //!< bytes
    size_t size;                //!< number of bytes
};

/** @brief The page's assets compiled into the program (generated at build time). */
const std::vector<EmbeddedAsset>& embeddedAssets();

/** @brief Frames of the video offered in the frame picker: up to @p max_frames evenly spaced
ones, always including @p frame. Throws cv::Exception when the video cannot be read or has
fewer frames than @p frame + 1. */
std::map<int, cv::Mat> loadPickerFrames(const std::string& video, int frame, int max_frames = 12);

/** @brief The state and API of one annotation session.

Every request must carry the session token as the first path component (`/<token>/…`), a
`Host` of 127.0.0.1:<port> or localhost:<port>, and, when it has an `Origin`, that same
origin; otherwise it gets 403. Routes under `/<token>/`: the page's assets (`""`,
`index.html`, `app.js`, `style.css`), and the JSON API `api/info`, `api/frame?i=N[&thumb=1]`,
`api/suggestions?i=N`, `api/calibrate` (POST), `api/save` (POST), `api/preview` (POST, with an
object). See doc/vbme_annotate.md. */
class AnnotateSession {
public:
    /** @brief A session on @p frames (index → 8-bit BGR) with a random token. */
    AnnotateSession(AnnotateConfig config, std::map<int, cv::Mat> frames);

    /** @brief Handles one request. Thread-safe. */
    AnnotateReply handle(const AnnotateRequest& request) const;

    /** @brief The secret that every request must carry. */
    const std::string& token() const { return token_; }
    /** @brief Sets the port the server listens on (for the Host/Origin checks). */
    void setPort(int port) { port_ = port; }
    /** @brief The port set by setPort(). */
    int port() const { return port_; }
    /** @brief The URL to open: http://127.0.0.1:<port>/<token>/ */
    std::string url() const;

private:
    AnnotateReply route(const AnnotateRequest& request, const std::string& rest) const;
    AnnotateReply info() const;
    AnnotateReply frame(const AnnotateRequest& request) const;
    AnnotateReply suggestions(const AnnotateRequest& request) const;
    AnnotateReply calibrate(const AnnotateRequest& request) const;
    AnnotateReply save(const AnnotateRequest& request) const;
    AnnotateReply preview(const AnnotateRequest& request) const;
    const cv::Mat& frameOf(const std::string& index_text) const;

    AnnotateConfig config_;
    std::map<int, cv::Mat> frames_;
    std::string token_;
    int port_ = 0;
    mutable std::mutex mutex_;  // guards the caches and saving
    mutable std::map<int, std::string> suggestion_cache_;
};

/** @brief A session behind cpp-httplib, bound to 127.0.0.1. */
class AnnotateServer {
public:
    /** @brief Binds to 127.0.0.1:@p port (0: a free port). Throws cv::Exception when the port
    cannot be bound. */
    AnnotateServer(std::shared_ptr<AnnotateSession> session, int port = 0);
    ~AnnotateServer();
    /** @brief Serves until stop() (blocking). */
    void run();
    /** @brief Stops run() (from another thread or a signal handler's thread). */
    void stop();
    /** @brief The bound port. */
    int port() const { return port_; }

private:
    struct Impl;
    std::unique_ptr<Impl> impl_;
    int port_ = 0;
};

}  // namespace vbme_app

#endif
