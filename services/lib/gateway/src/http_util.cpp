#include "http_util.hpp"

#include <algorithm>
#include <sstream>

#include "urs/gateway/json_writer.hpp"

namespace urs::gateway::http_util {

std::string cookie(const Request& request, const std::string& name) {
  const auto header = request.find(http::field::cookie);
  if (header == request.end()) return {};
  const std::string text(header->value());
  std::size_t at = 0;
  while (at < text.size()) {
    const auto end = std::min(text.find(';', at), text.size());
    std::string pair = text.substr(at, end - at);
    const auto first = pair.find_first_not_of(' ');
    pair = first == std::string::npos ? "" : pair.substr(first);
    const auto equals = pair.find('=');
    if (equals != std::string::npos && pair.substr(0, equals) == name) return pair.substr(equals + 1);
    at = end + 1;
  }
  return {};
}

std::string query(const std::string& target, const std::string& name) {
  const auto mark = target.find('?');
  if (mark == std::string::npos) return {};
  std::stringstream parts(target.substr(mark + 1));
  std::string part;
  while (std::getline(parts, part, '&')) {
    if (part.rfind(name + "=", 0) == 0) return part.substr(name.size() + 1);
  }
  return {};
}

std::string path_of(const std::string& target) { return target.substr(0, target.find('?')); }

const char* content_type(const std::string& path) {
  const auto dot = path.rfind('.');
  const std::string extension = dot == std::string::npos ? "" : path.substr(dot + 1);
  if (extension == "html") return "text/html; charset=utf-8";
  if (extension == "js") return "text/javascript; charset=utf-8";
  if (extension == "css") return "text/css; charset=utf-8";
  if (extension == "svg") return "image/svg+xml";
  if (extension == "png") return "image/png";
  if (extension == "json") return "application/json";
  if (extension == "ico") return "image/x-icon";
  return "application/octet-stream";
}

bool safe_path(const std::string& path) {
  if (path.empty() || path.front() != '/' || path.size() > 200) return false;
  for (char c : path) {
    const bool ok = (c >= 'a' && c <= 'z') || (c >= 'A' && c <= 'Z') || (c >= '0' && c <= '9') || c == '-' ||
                    c == '_' || c == '.' || c == '/';
    if (!ok) return false;
  }
  return path.find("..") == std::string::npos && path.find("//") == std::string::npos;
}

Response respond(const Request& request, http::status status, std::string body, const char* type) {
  Response response{status, request.version()};
  response.set(http::field::server, "urs-gateway");
  response.set(http::field::content_type, type);
  response.set(http::field::cache_control, "no-store");
  response.set("X-Content-Type-Options", "nosniff");
  response.set("X-Frame-Options", "DENY");
  response.set("Content-Security-Policy",
               "default-src 'self'; connect-src 'self' ws: wss:; img-src 'self' data:; style-src 'self'; "
               "frame-ancestors 'none'");
  response.keep_alive(request.keep_alive());
  response.body() = std::move(body);
  response.prepare_payload();
  return response;
}

Response json_response(const Request& request, http::status status, std::string json) {
  return respond(request, status, std::move(json), "application/json");
}

Response error_response(const Request& request, http::status status, const std::string& message) {
  JsonWriter out;
  out.begin_object().key("error").value(message).end_object();
  return json_response(request, status, out.take());
}

}  // namespace urs::gateway::http_util
