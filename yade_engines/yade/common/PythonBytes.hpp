// Python bytes <-> std::string for the engines' restart states (state streams handed to and taken from Python).
#pragma once

#include <boost/python.hpp>

#include <stdexcept>
#include <string>

namespace yade {

/// The content of a Python bytes object; throws std::invalid_argument naming `what` for anything else.
inline std::string bytesFromPython(const boost::python::object& value, const std::string& what) {
  char* data = nullptr;
  Py_ssize_t size = 0;
  if (!PyBytes_Check(value.ptr()) || PyBytes_AsStringAndSize(value.ptr(), &data, &size) != 0)
    throw std::invalid_argument(what + " must be bytes");
  return std::string(data, static_cast<std::size_t>(size));
}

/// A Python bytes object holding `bytes`.
inline boost::python::object pythonBytes(const std::string& bytes) {
  return boost::python::object(boost::python::handle<>(PyBytes_FromStringAndSize(bytes.data(), bytes.size())));
}

} // namespace yade
