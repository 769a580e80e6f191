#include "urs/rtc/naming.hpp"

#include <stdexcept>

#include "urs/rtc/orb.hpp"

namespace urs::rtc {
namespace {

std::vector<std::string> split_path(const std::string& path) {
  std::vector<std::string> parts;
  std::string::size_type start = 0;
  while (true) {
    const auto slash = path.find('/', start);
    parts.push_back(path.substr(start, slash == std::string::npos ? std::string::npos : slash - start));
    if (slash == std::string::npos) break;
    start = slash + 1;
  }
  return parts;
}

std::string why(const CosNaming::NamingContext::NotFound& e) {
  switch (e.why) {
    case CosNaming::NamingContext::missing_node:
      return "not bound";
    case CosNaming::NamingContext::not_context:
      return "not a naming context";
    case CosNaming::NamingContext::not_object:
      return "not an object";
  }
  return "not found";
}

}  // namespace

CosNaming::Name to_name(const std::string& path) {
  if (path.empty()) throw std::invalid_argument("empty naming path");
  const auto parts = split_path(path);
  CosNaming::Name name;
  name.length(static_cast<CORBA::ULong>(parts.size()));
  for (CORBA::ULong i = 0; i < name.length(); ++i) {
    const std::string& part = parts[i];
    if (part.empty()) throw std::invalid_argument("empty name component in naming path \"" + path + "\"");
    const auto dot = part.rfind('.');
    name[i].id = CORBA::string_dup(part.substr(0, dot).c_str());
    name[i].kind = CORBA::string_dup(dot == std::string::npos ? "" : part.substr(dot + 1).c_str());
  }
  return name;
}

std::string to_path(const CosNaming::Name& name) {
  std::string path;
  for (CORBA::ULong i = 0; i < name.length(); ++i) {
    if (i > 0) path += '/';
    path += name[i].id.in();
    const std::string kind = name[i].kind.in();
    if (!kind.empty()) path += "." + kind;
  }
  return path;
}

std::string component_path(const std::string& host, const std::string& instance) {
  return host + ".host_cxt/" + instance + ".rtc";
}

NamingClient::NamingClient(const Orb& orb, const std::string& host_port) : orb_(orb), address_(host_port) {}

CosNaming::NamingContext_ptr NamingClient::root() {
  std::lock_guard lock(root_mutex_);
  if (CORBA::is_nil(root_)) {
    try {
      CORBA::Object_var object = orb_.string_to_object("corbaloc:iiop:" + address_ + "/NameService");
      root_ = CosNaming::NamingContext::_narrow(object);
    } catch (const std::invalid_argument& e) {
      throw NamingError("naming service " + address_ + ": " + e.what());
    } catch (const CORBA::Exception& e) {
      throw NamingUnreachable("naming service " + address_ + " unreachable: " + describe(e));
    }
    if (CORBA::is_nil(root_)) throw NamingError("naming service " + address_ + ": not a naming context");
  }
  return root_.in();
}

CORBA::Object_ptr NamingClient::try_resolve(const std::string& path) {
  try {
    return root()->resolve(to_name(path));
  } catch (const CosNaming::NamingContext::NotFound&) {
    return CORBA::Object::_nil();
  } catch (const CORBA::UserException& e) {
    throw NamingError("resolve " + path + ": " + describe(e));
  } catch (const CORBA::SystemException& e) {
    throw NamingUnreachable("naming service " + address_ + " unreachable: " + describe(e));
  }
}

CORBA::Object_ptr NamingClient::resolve(const std::string& path) {
  try {
    return root()->resolve(to_name(path));
  } catch (const CosNaming::NamingContext::NotFound& e) {
    throw NamingError(path + ": " + why(e));
  } catch (const CORBA::UserException& e) {
    throw NamingError("resolve " + path + ": " + describe(e));
  } catch (const CORBA::SystemException& e) {
    throw NamingUnreachable("naming service " + address_ + " unreachable: " + describe(e));
  }
}

CosNaming::NamingContext_ptr NamingClient::context_at(const std::string& path) {
  if (path.empty()) return CosNaming::NamingContext::_duplicate(root());
  CORBA::Object_var object = resolve(path);
  CosNaming::NamingContext_var context;
  try {
    context = CosNaming::NamingContext::_narrow(object);
  } catch (const CORBA::SystemException& e) {
    throw NamingError(path + ": " + describe(e));
  }
  if (CORBA::is_nil(context)) throw NamingError(path + ": not a naming context");
  return context._retn();
}

void NamingClient::bind_with_parents(const std::string& path, CORBA::Object_ptr object, bool replace) {
  const CosNaming::Name name = to_name(path);
  try {
    CosNaming::NamingContext_var context = CosNaming::NamingContext::_duplicate(root());
    for (CORBA::ULong i = 0; i + 1 < name.length(); ++i) {
      CosNaming::Name step;
      step.length(1);
      step[0] = name[i];
      CosNaming::NamingContext_var next;
      try {
        next = context->bind_new_context(step);
      } catch (const CosNaming::NamingContext::AlreadyBound&) {
        CORBA::Object_var existing = context->resolve(step);
        next = CosNaming::NamingContext::_narrow(existing);
        if (CORBA::is_nil(next))
          throw NamingError(path + ": " + to_path(step) + " is bound to an object, not a context");
      }
      context = next;
    }
    CosNaming::Name last;
    last.length(1);
    last[0] = name[name.length() - 1];
    if (replace) {
      context->rebind(last, object);
    } else {
      context->bind(last, object);
    }
  } catch (const CosNaming::NamingContext::AlreadyBound&) {
    throw NamingError(path + ": already bound");
  } catch (const CORBA::UserException& e) {
    throw NamingError("bind " + path + ": " + describe(e));
  } catch (const CORBA::SystemException& e) {
    throw NamingUnreachable("naming service " + address_ + " unreachable: " + describe(e));
  }
}

void NamingClient::bind(const std::string& path, CORBA::Object_ptr object) { bind_with_parents(path, object, false); }

void NamingClient::rebind(const std::string& path, CORBA::Object_ptr object) { bind_with_parents(path, object, true); }

bool NamingClient::unbind(const std::string& path) {
  try {
    root()->unbind(to_name(path));
    return true;
  } catch (const CosNaming::NamingContext::NotFound&) {
    return false;
  } catch (const CORBA::UserException& e) {
    throw NamingError("unbind " + path + ": " + describe(e));
  } catch (const CORBA::SystemException& e) {
    throw NamingUnreachable("naming service " + address_ + " unreachable: " + describe(e));
  }
}

std::vector<NamingClient::Entry> NamingClient::list(const std::string& path) {
  CosNaming::NamingContext_var context = context_at(path);
  std::vector<Entry> entries;
  try {
    CosNaming::BindingList_var bindings;
    CosNaming::BindingIterator_var rest;
    context->list(1000, bindings.out(), rest.out());
    auto add = [&](const CosNaming::BindingList& list) {
      for (CORBA::ULong i = 0; i < list.length(); ++i) {
        const CosNaming::Binding& b = list[i];
        if (b.binding_name.length() == 0) continue;
        Entry entry;
        entry.id = b.binding_name[0].id.in();
        entry.kind = b.binding_name[0].kind.in();
        entry.is_context = b.binding_type == CosNaming::ncontext;
        entry.path = (path.empty() ? "" : path + "/") + to_path(b.binding_name);
        entries.push_back(std::move(entry));
      }
    };
    add(bindings.in());
    if (!CORBA::is_nil(rest)) {
      CosNaming::BindingList_var more;
      while (rest->next_n(1000, more.out())) add(more.in());
      rest->destroy();
    }
  } catch (const CORBA::SystemException& e) {
    throw NamingUnreachable("naming service " + address_ + " unreachable: " + describe(e));
  }
  return entries;
}

std::vector<NamingClient::Entry> NamingClient::list_objects(const std::string& path) {
  std::vector<Entry> objects;
  for (Entry& entry : list(path)) {
    if (entry.is_context) {
      for (Entry& inner : list_objects(entry.path)) objects.push_back(std::move(inner));
    } else {
      objects.push_back(std::move(entry));
    }
  }
  return objects;
}

}  // namespace urs::rtc
