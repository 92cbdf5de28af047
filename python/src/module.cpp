// The `kiji._kiji` extension module: libkiji for Python. The `kiji` package wraps it (tool methods,
// stubs, examples); see python/kiji/__init__.py.
#include "bindings.h"

#include "kiji/version.h"

PYBIND11_MODULE(_kiji, m) {
  m.doc() = "Kiji's core: garments, bodies, the solver, tools, sessions and their journal.";
  m.def("version", &kiji::version, "Kiji's version.");
  m.def("abi_tag", &kiji::abi_tag, "The ABI tag that tool plugins must have been built with.");
  kiji::python::bind_errors(m);
  kiji::python::bind_scene(m);
  kiji::python::bind_garment(m);
  kiji::python::bind_session(m);
  kiji::python::bind_interactive(m);
  kiji::python::bind_solver(m);
  kiji::python::bind_topology(m);
  kiji::python::bind_operations(m);
  kiji::python::bind_collision(m);
  kiji::python::bind_haptics(m);
  kiji::python::bind_tools(m);
  kiji::python::bind_peer(m);
}
