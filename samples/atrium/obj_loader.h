// Wavefront OBJ loading (positions, normals, texture coordinates, polygons, usemtl). Material
// libraries and image textures are not read: each material name is mapped onto one of the
// procedural textures.
#pragma once

#include "scene.h"

#include <string>

namespace atrium {

// Throws Error("path:line: reason") on unreadable or malformed input.
Scene load_obj(const std::string &path);

// The procedural texture used for an OBJ material: by keyword (fabric, floor, column, ...), else
// by a hash of the name.
uint32_t texture_for_material(const std::string &name);

} // namespace atrium
