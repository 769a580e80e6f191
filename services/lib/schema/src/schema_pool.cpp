// SchemaPool: a DescriptorPool backed by a database of accepted files.
//
// Why a fallback database: a DescriptorPool is only internally locked when it has one, and
// lookups (ours, and those the JSON functions make through descriptor->file()->pool()) must be
// safe while another thread adds files. Files are validated in a scratch pool first, so a bad
// set never reaches the shared pool (which remembers failed files forever).
#include <google/protobuf/descriptor.pb.h>
#include <google/protobuf/descriptor_database.h>

#include <algorithm>
#include <map>
#include <set>

#include "urs/schema/schema.hpp"

namespace urs::schema {

namespace gp = google::protobuf;

namespace {

bool is_well_known(const std::string& file_name) { return file_name.rfind("google/protobuf/", 0) == 0; }

void strip_json_names(gp::DescriptorProto& message) {
  for (auto& field : *message.mutable_field()) field.clear_json_name();
  for (auto& field : *message.mutable_extension()) field.clear_json_name();
  for (auto& nested : *message.mutable_nested_type()) strip_json_names(nested);
}

// Content used to decide whether two files with one name are the same: source locations and
// JSON names (which protoc and FileDescriptor::CopyTo fill in differently) do not count.
std::string canonical(gp::FileDescriptorProto file) {
  file.clear_source_code_info();
  for (auto& message : *file.mutable_message_type()) strip_json_names(message);
  for (auto& field : *file.mutable_extension()) field.clear_json_name();
  return file.SerializeAsString();
}

// Names a file defines at package level (where two files of one package can clash).
std::vector<std::string> top_level_symbols(const gp::FileDescriptor& file) {
  std::vector<std::string> out;
  for (int i = 0; i < file.message_type_count(); ++i) out.push_back(file.message_type(i)->full_name());
  for (int i = 0; i < file.enum_type_count(); ++i) {
    const gp::EnumDescriptor* type = file.enum_type(i);
    out.push_back(type->full_name());
    for (int v = 0; v < type->value_count(); ++v) out.push_back(type->value(v)->full_name());
  }
  for (int i = 0; i < file.service_count(); ++i) out.push_back(file.service(i)->full_name());
  for (int i = 0; i < file.extension_count(); ++i) out.push_back(file.extension(i)->full_name());
  return out;
}

const gp::FileDescriptor* file_defining(const gp::DescriptorPool& pool, const std::string& symbol) {
  if (const auto* d = pool.FindMessageTypeByName(symbol)) return d->file();
  if (const auto* d = pool.FindEnumTypeByName(symbol)) return d->file();
  if (const auto* d = pool.FindEnumValueByName(symbol)) return d->type()->file();
  if (const auto* d = pool.FindServiceByName(symbol)) return d->file();
  if (const auto* d = pool.FindExtensionByName(symbol)) return d->file();
  return nullptr;
}

}  // namespace

// Collects a pool's build errors as "file: element: message; ...". Thread-safe.
class SchemaPool::Errors final : public gp::DescriptorPool::ErrorCollector {
 public:
  void AddError(const std::string& filename, const std::string& element_name, const gp::Message* /*descriptor*/,
                ErrorLocation /*location*/, const std::string& message) override {
    std::lock_guard<std::mutex> lock(mutex_);
    if (!text_.empty()) text_ += "; ";
    text_ += filename + ": ";
    if (!element_name.empty() && element_name != filename) text_ += element_name + ": ";
    text_ += message;
  }

  std::string take() {
    std::lock_guard<std::mutex> lock(mutex_);
    std::string out;
    out.swap(text_);
    return out;
  }

 private:
  std::mutex mutex_;
  std::string text_;
};

// The accepted files, indexed; thread-safe (the pool queries it under its own lock, adds come
// from add_descriptor_set()).
class SchemaPool::Database final : public gp::DescriptorDatabase {
 public:
  bool FindFileByName(const std::string& filename, gp::FileDescriptorProto* output) override {
    std::lock_guard<std::mutex> lock(mutex_);
    return index_->FindFileByName(filename, output);
  }
  bool FindFileContainingSymbol(const std::string& symbol_name, gp::FileDescriptorProto* output) override {
    std::lock_guard<std::mutex> lock(mutex_);
    return index_->FindFileContainingSymbol(symbol_name, output);
  }
  bool FindFileContainingExtension(const std::string& containing_type, int field_number,
                                   gp::FileDescriptorProto* output) override {
    std::lock_guard<std::mutex> lock(mutex_);
    return index_->FindFileContainingExtension(containing_type, field_number, output);
  }
  bool FindAllExtensionNumbers(const std::string& extendee_type, std::vector<int>* output) override {
    std::lock_guard<std::mutex> lock(mutex_);
    return index_->FindAllExtensionNumbers(extendee_type, output);
  }
  bool FindAllFileNames(std::vector<std::string>* output) override {
    std::lock_guard<std::mutex> lock(mutex_);
    for (const auto& entry : files_) output->push_back(entry.first);
    return true;
  }

  // The stored file named `name`, or nullptr. The pointer stays valid until remove().
  const gp::FileDescriptorProto* get(const std::string& name) const {
    std::lock_guard<std::mutex> lock(mutex_);
    auto found = files_.find(name);
    return found == files_.end() ? nullptr : &found->second;
  }

  // False (and nothing added) if the index rejects a file (a symbol defined twice).
  bool add(const std::vector<gp::FileDescriptorProto>& files) {
    std::lock_guard<std::mutex> lock(mutex_);
    for (const auto& file : files) files_[file.name()] = file;
    auto index = std::make_unique<gp::SimpleDescriptorDatabase>();
    for (const auto& entry : files_) {
      if (!index->Add(entry.second)) {
        for (const auto& file : files) files_.erase(file.name());
        return false;
      }
    }
    index_ = std::move(index);
    return true;
  }

  void remove(const std::vector<gp::FileDescriptorProto>& files) {
    std::lock_guard<std::mutex> lock(mutex_);
    for (const auto& file : files) files_.erase(file.name());
    auto index = std::make_unique<gp::SimpleDescriptorDatabase>();
    for (const auto& entry : files_) index->Add(entry.second);
    index_ = std::move(index);
  }

 private:
  mutable std::mutex mutex_;
  std::map<std::string, gp::FileDescriptorProto> files_;
  std::unique_ptr<gp::SimpleDescriptorDatabase> index_ = std::make_unique<gp::SimpleDescriptorDatabase>();
};

SchemaPool::SchemaPool()
    : database_(std::make_unique<Database>()),
      errors_(std::make_unique<Errors>()),
      pool_(std::make_unique<gp::DescriptorPool>(database_.get(), errors_.get())) {}

SchemaPool::~SchemaPool() = default;

std::string SchemaPool::add_descriptor_set(const std::string& bytes) {
  gp::FileDescriptorSet set;
  if (!set.ParseFromString(bytes)) {
    return "the " + std::to_string(bytes.size()) +
           " bytes received are not a serialized google.protobuf.FileDescriptorSet";
  }
  std::lock_guard<std::mutex> lock(add_mutex_);

  // 1. Sort out files already known, and duplicates inside the set.
  std::vector<gp::FileDescriptorProto> fresh;
  std::map<std::string, std::string> fresh_content;
  for (const auto& file : set.file()) {
    if (file.name().empty()) return "the descriptor set holds a file without a name";
    const std::string content = canonical(file);
    if (const gp::FileDescriptorProto* known = database_->get(file.name())) {
      if (is_well_known(file.name()) || canonical(*known) == content) continue;
      return "file '" + file.name() +
             "' is already loaded with a different content (another version of "
             "the interface?); keep one version per pool";
    }
    auto [it, inserted] = fresh_content.emplace(file.name(), content);
    if (!inserted) {
      if (it->second == content) continue;
      return "the descriptor set holds two different files named '" + file.name() + "'";
    }
    fresh.push_back(file);
  }
  if (fresh.empty()) return {};

  // 2. Build the new files in a scratch pool over (loaded files + the set): unresolved names,
  //    missing imports, bad options... are reported without touching the shared pool.
  gp::SimpleDescriptorDatabase incoming;
  for (const auto& file : fresh) {
    if (!incoming.Add(file)) {
      return "file '" + file.name() + "' defines a name that another file of the descriptor set also defines";
    }
  }
  gp::MergedDescriptorDatabase merged(database_.get(), &incoming);
  Errors scratch_errors;
  gp::DescriptorPool scratch(&merged, &scratch_errors);
  for (const auto& file : fresh) {
    const gp::FileDescriptor* built = scratch.FindFileByName(file.name());
    if (built == nullptr) {
      std::string details = scratch_errors.take();
      if (details.empty()) details = "it cannot be built";
      return "cannot load file '" + file.name() + "': " + details;
    }
    // 3. Names that a loaded, unrelated file already defines.
    for (const std::string& symbol : top_level_symbols(*built)) {
      if (const gp::FileDescriptor* other = file_defining(*pool_, symbol)) {
        return "cannot load file '" + file.name() + "': it defines '" + symbol + "', which loaded file '" +
               other->name() + "' already defines; rename one of them";
      }
    }
  }

  // 4. Publish, then build in the shared pool (expected to succeed after the checks above).
  if (!database_->add(fresh)) {
    return "cannot load the descriptor set: one of its files (" + fresh.front().name() +
           "...) defines a name that a loaded file already defines";
  }
  for (const auto& file : fresh) {
    if (pool_->FindFileByName(file.name()) == nullptr) {
      database_->remove(fresh);
      std::string details = errors_->take();
      return "cannot load file '" + file.name() + "': " + (details.empty() ? "it cannot be built" : details);
    }
  }
  return {};
}

const gp::ServiceDescriptor* SchemaPool::find_service(const std::string& full_name) const {
  return pool_->FindServiceByName(full_name);
}

const gp::Descriptor* SchemaPool::find_message(const std::string& full_name) const {
  return pool_->FindMessageTypeByName(full_name);
}

const gp::EnumDescriptor* SchemaPool::find_enum(const std::string& full_name) const {
  return pool_->FindEnumTypeByName(full_name);
}

const gp::MethodDescriptor* SchemaPool::find_method(const std::string& full_name) const {
  return pool_->FindMethodByName(full_name);
}

std::vector<std::string> SchemaPool::service_names() const {
  std::vector<std::string> files;
  database_->FindAllFileNames(&files);
  std::vector<std::string> out;
  for (const auto& name : files) {
    const gp::FileDescriptor* file = pool_->FindFileByName(name);
    if (file == nullptr) continue;
    for (int i = 0; i < file->service_count(); ++i) out.push_back(file->service(i)->full_name());
  }
  std::sort(out.begin(), out.end());
  return out;
}

std::unique_ptr<gp::Message> SchemaPool::new_message(const gp::Descriptor& type) const {
  return std::unique_ptr<gp::Message>(factory_.GetPrototype(&type)->New());
}

}  // namespace urs::schema
