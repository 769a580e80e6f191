#pragma once
// The HTTP pieces the gateway's sessions share (Boost.Beast): a request's cookie, query parameter
// and path, which paths of the dashboard may be served and as what content type, and the
// responses, every one with the same security headers (no caching, no sniffing, no framing, a
// same-origin content security policy). Functions of their arguments only: any thread, no I/O,
// nothing thrown but std::bad_alloc.

#include <boost/beast/http.hpp>
#include <string>

namespace urs::gateway {

namespace beast = boost::beast;
namespace http = beast::http;
using Request = http::request<http::string_body>;
using Response = http::response<http::string_body>;

namespace http_util {

// The value of cookie `name` in a Cookie header ("a=1; b=2"), "" if absent.
std::string cookie(const Request& request, const std::string& name);

// The value of query parameter `name` in a target ("/?session=ab"), "" if absent. Ids are hex:
// nothing to decode.
std::string query(const std::string& target, const std::string& name);

// The target without its query.
std::string path_of(const std::string& target);

// The content type of a dashboard file, from its extension (application/octet-stream if unknown).
const char* content_type(const std::string& path);

// A path of the dashboard's files: at most 200 characters, letters, digits, '-', '_', '.', '/',
// starting with '/', no ".." and no "//".
bool safe_path(const std::string& path);

// A response to `request` (its HTTP version and keep-alive) with the security headers.
Response respond(const Request& request, http::status status, std::string body, const char* type);
Response json_response(const Request& request, http::status status, std::string json);
// {"error": message}
Response error_response(const Request& request, http::status status, const std::string& message);

}  // namespace http_util
}  // namespace urs::gateway
