#include "urs/gateway/logins.hpp"

#include <spdlog/spdlog.h>

#include <cstdio>
#include <random>

#include "urs/planet/authenticator.hpp"

namespace urs::gateway {

using Clock = std::chrono::steady_clock;

bool same_secret(const std::string& a, const std::string& b) {
  if (a.size() != b.size()) return false;
  unsigned char difference = 0;
  for (std::size_t i = 0; i < a.size(); ++i) difference |= static_cast<unsigned char>(a[i] ^ b[i]);
  return difference == 0;
}

std::string random_id() {
  std::random_device random;  // getrandom() on Linux
  std::string id;
  for (int i = 0; i < 4; ++i) {
    char part[9];
    std::snprintf(part, sizeof part, "%08x", static_cast<unsigned>(random()));
    id += part;
  }
  return id;
}

Role role_for(planet::Role server_role, bool read_only) {
  return server_role == planet::OPERATOR && !read_only ? Role::operator_ : Role::viewer;
}

Logins::Logins(LoginOptions options) : options_(std::move(options)) {}

Logins::~Logins() {
  std::map<std::string, Entry> left;
  {
    std::lock_guard lock(mutex_);
    left.swap(logins_);
  }
  // Their Planet sessions close here, outside the lock.
}

void Logins::purge(Clock::time_point now) {
  for (auto it = logins_.begin(); it != logins_.end();) {
    if (now - it->second.used > options_.idle) {
      it = logins_.erase(it);
    } else {
      ++it;
    }
  }
}

bool Logins::failed_too_often(Clock::time_point now) {
  std::lock_guard lock(mutex_);
  while (!failures_.empty() && now - failures_.front() > std::chrono::minutes(1)) failures_.pop_front();
  return failures_.size() >= options_.max_failures_per_minute;
}

void Logins::failed(Clock::time_point now) {
  std::lock_guard lock(mutex_);
  failures_.push_back(now);
}

LoginResult Logins::login(const std::string& credential) {
  const auto now = Clock::now();
  if (failed_too_often(now)) {
    return {nullptr, 429, "too many failed logins in the last minute; try again later"};
  }
  if (credential.empty() || credential.size() > 4096) {
    failed(now);
    return {nullptr, 401, "no credential given (or one longer than 4096 bytes)"};
  }
  auto made = std::make_shared<Login>();
  made->id = random_id();
  made->number = ++numbered_;
  if (!options_.viewer_token.empty() && same_secret(credential, options_.viewer_token)) {
    made->role = Role::viewer;
  } else if (options_.camus) {
    planet::ClientOptions client = *options_.camus;
    client.token = credential;
    client.peer_name = options_.camus->peer_name + "/login-" + std::to_string(made->number);
    auto session = std::make_unique<planet::Client>(client);
    session->start();
    if (!session->wait_connected(options_.verify_timeout)) {
      const std::string why = session->last_error();
      session->stop();
      if (why.find("refused") != std::string::npos) {
        failed(now);
        return {nullptr, 401, "the CAMUS server refused the credential (" + why + ")"};
      }
      return {nullptr, 503, "the CAMUS server cannot be reached: " + (why.empty() ? "no answer" : why)};
    }
    // The role the server gives this credential (its Welcome): only an operator acts here.
    made->server_role = session->welcome().role();
    made->identity = session->welcome().identity();
    made->role = role_for(made->server_role, options_.read_only);
    made->client = std::move(session);
  } else if (!options_.space_token.empty() && same_secret(credential, options_.space_token)) {
    made->role = options_.read_only ? Role::viewer : Role::operator_;
  } else {
    failed(now);
    return {nullptr, 401, "wrong credential"};
  }
  std::shared_ptr<const Login> login = made;
  std::lock_guard lock(mutex_);
  purge(now);
  if (logins_.size() >= options_.max_logins) {
    return {nullptr, 503, "too many logins (" + std::to_string(options_.max_logins) + "); log out elsewhere first"};
  }
  logins_[login->id] = Entry{login, now};
  if (login->identity.empty()) {
    spdlog::info("gateway: login #{} as {}", login->number, role_name(login->role));
  } else {
    spdlog::info("gateway: login #{} as {} (credential '{}', role {} at the CAMUS server)", login->number,
                 role_name(login->role), login->identity, planet::role_word(login->server_role));
  }
  return {login, 200, {}};
}

std::shared_ptr<const Login> Logins::find(const std::string& id) {
  const auto now = Clock::now();
  std::lock_guard lock(mutex_);
  purge(now);
  auto it = logins_.find(id);
  if (it == logins_.end()) return nullptr;
  it->second.used = now;
  return it->second.login;
}

bool Logins::logout(const std::string& id) {
  std::shared_ptr<const Login> gone;
  {
    std::lock_guard lock(mutex_);
    auto it = logins_.find(id);
    if (it == logins_.end()) return false;
    gone = it->second.login;
    logins_.erase(it);
  }
  return true;
}

std::size_t Logins::size() const {
  std::lock_guard lock(mutex_);
  return logins_.size();
}

}  // namespace urs::gateway
