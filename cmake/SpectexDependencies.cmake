# Imported targets of Debian 12's packages (see DESIGN.md, "Facts about Debian 12's packages").
find_package(Eigen3 3.3 REQUIRED NO_MODULE)
find_package(Imath REQUIRED CONFIG)
find_package(OpenEXR REQUIRED CONFIG)
find_package(OpenImageIO REQUIRED CONFIG)

# Debian's OpenImageIO target names /usr/include/opencv4, which need not exist.
get_target_property(_oiio_inc OpenImageIO::OpenImageIO INTERFACE_INCLUDE_DIRECTORIES)
if(_oiio_inc)
  list(FILTER _oiio_inc EXCLUDE REGEX "opencv4")
  set_target_properties(OpenImageIO::OpenImageIO PROPERTIES INTERFACE_INCLUDE_DIRECTORIES "${_oiio_inc}")
endif()

# find_package(OpenColorIO CONFIG) resolves its prefix to "/" on Debian 12: use pkg-config.
find_package(PkgConfig REQUIRED)
pkg_check_modules(OCIO REQUIRED IMPORTED_TARGET OpenColorIO)
if(NOT TARGET OpenColorIO::OpenColorIO)
  add_library(OpenColorIO::OpenColorIO ALIAS PkgConfig::OCIO)
endif()

# libdeflate: the core-API writer deflates EXR ZIP blocks with it (OpenEXR >= 3.2 does the same;
# Debian 12's 3.1.5 uses zlib, about 1.7x the CPU time for the same standard stream).
pkg_check_modules(LIBDEFLATE REQUIRED IMPORTED_TARGET libdeflate)

# JSON reports (bake --json, info/verify/sample --json, plan --json) are built with nlohmann-json
# (nlohmann-json3-dev): its escaping and number output replace hand-written ones. Header-only.
find_package(nlohmann_json 3.11 REQUIRED CONFIG)

find_package(Threads REQUIRED)
