// The glTF 2.0 reader: the library's one C++ file. It wraps tinygltf (the prebuilt
// Debian library; TINYGLTF_IMPLEMENTATION is deliberately not defined here) behind the
// C view declared in gltf_shim_internal.h.
//
// Inside this file failures are thrown as `failure` and every exception is caught at
// the C boundary, so no C++ exception ever unwinds through C frames. tinygltf checks
// the JSON syntax and the shape of each object, but not most references between
// objects nor whether accessors fit their buffers; all of that is checked here before
// any byte of a buffer is read.
#include "gltf_shim_internal.h"

#include "camera_internal.h"

#include <sys/stat.h>

#include <tiny_gltf.h>

#include <cerrno>
#include <cmath>
#include <cstdarg>
#include <cstdio>
#include <cstring>
#include <deque>
#include <exception>
#include <limits>
#include <map>
#include <memory>
#include <new>
#include <string>
#include <utility>
#include <vector>

namespace {

// A failure raised anywhere below and turned into a bbc_result at the C boundary.
struct failure {
  bbc_result code;
  std::string message;
};

[[noreturn]] __attribute__((format(printf, 2, 3))) void fail(bbc_result code, const char *fmt,
                                                             ...) {
  char message[768];
  va_list ap;
  va_start(ap, fmt);
  vsnprintf(message, sizeof message, fmt, ap);
  va_end(ap);
  throw failure{code, message};
}

// Owns everything the C view points to. Deques keep the addresses of their elements
// stable as they grow, so the pointers handed out stay valid.
struct holder {
  bbc__gltf_data view{};
  std::deque<std::string> strings;
  std::deque<std::vector<float>> floats;
  std::deque<std::vector<uint32_t>> indices;
  std::vector<bbc__gltf_primitive> primitives;
  std::vector<bbc__gltf_material> materials;
  std::vector<bbc__gltf_texture> textures;
  std::vector<bbc__gltf_image> images;
  std::deque<std::vector<unsigned char>> pixels;
  std::vector<bbc__gltf_light> lights;
  std::vector<const char *> notes;
  std::vector<bbc__gltf_camera> cameras;
  std::deque<bbc__gltf_channel> channels;
  std::deque<std::vector<bbc__gltf_node_motion>> paths;

  const char *keep(const std::string &s) {
    strings.push_back(s);
    return strings.back().c_str();
  }
};

// The file-system callbacks given to tinygltf. They replace its defaults, which expand
// paths with wordexp (so a '$' or a space in a folder name changes the path) and also
// search the current directory; here a buffer is found beside the glTF file or not
// at all, and nothing is ever written.
struct fs_context {
  bool allowed = false;  // false when parsing from memory without a base folder
  std::string base_dir;
};

bool fs_file_exists(const std::string &path, void *user) {
  const fs_context *ctx = static_cast<const fs_context *>(user);
  if (!ctx->allowed || path.compare(0, ctx->base_dir.size(), ctx->base_dir) != 0) return false;
  struct stat st;
  return stat(path.c_str(), &st) == 0 && S_ISREG(st.st_mode);
}

std::string fs_expand_file_path(const std::string &path, void *) {
  return path;
}

bool read_whole_file(const std::string &path, std::vector<unsigned char> *out, std::string *why) {
  FILE *f = fopen(path.c_str(), "rb");
  if (!f) {
    *why = strerror(errno);
    return false;
  }
  struct stat st;
  if (fstat(fileno(f), &st) == 0 && S_ISDIR(st.st_mode)) {
    fclose(f);
    *why = "is a directory";
    return false;
  }
  out->clear();
  unsigned char chunk[65536];
  size_t n;
  while ((n = fread(chunk, 1, sizeof chunk, f)) > 0) out->insert(out->end(), chunk, chunk + n);
  bool ok = !ferror(f);
  if (!ok) *why = strerror(errno);
  fclose(f);
  return ok;
}

bool fs_read_whole_file(std::vector<unsigned char> *out, std::string *err, const std::string &path,
                        void *user) {
  const fs_context *ctx = static_cast<const fs_context *>(user);
  std::string why;
  if (!ctx->allowed) {
    if (err) *err = "external files are not allowed here";
    return false;
  }
  if (!read_whole_file(path, out, &why)) {
    if (err) *err = why;
    return false;
  }
  return true;
}

bool fs_write_whole_file(std::string *err, const std::string &, const std::vector<unsigned char> &,
                         void *) {
  if (err) *err = "bbc never writes glTF files";
  return false;
}

// The encoded bytes of every image, kept by the image callback while tinygltf parses;
// the reader decodes those that material textures use. Nothing is decoded in the
// callback, so an unused or broken image never stops a scene from loading.
struct image_store {
  const tinygltf::Model *model = nullptr;  // the model being parsed
  std::map<int, std::vector<unsigned char>> raw;
  std::map<int, std::string> problems;
};

bool keep_image(tinygltf::Image *image, const int index, std::string *, std::string *, int, int,
                const unsigned char *bytes, int size, void *user) {
  image_store *store = static_cast<image_store *>(user);
  if (image->bufferView >= 0) {
    // tinygltf does not check that a bufferView lies inside its buffer; it is checked
    // here before a byte of it is read (buffers and bufferViews are parsed by now).
    const tinygltf::Model &m = *store->model;
    bool inside = size_t(image->bufferView) < m.bufferViews.size();
    if (inside) {
      const tinygltf::BufferView &bv = m.bufferViews[size_t(image->bufferView)];
      inside = bv.buffer >= 0 && size_t(bv.buffer) < m.buffers.size() &&
               bv.byteOffset <= m.buffers[size_t(bv.buffer)].data.size() &&
               bv.byteLength <= m.buffers[size_t(bv.buffer)].data.size() - bv.byteOffset;
    }
    if (!inside) {
      store->problems[index] = "its bufferView lies outside its buffer";
      return true;
    }
  }
  if (bytes && size > 0) store->raw[index].assign(bytes, bytes + size);
  return true;
}

// tinygltf's messages may span several lines; the error callback gets exactly one.
// They also quote whole data URIs, so a word that is a data URI is cut after 60
// characters; every other word (a file's path above all) is kept whole.
std::string one_line(const std::string &text) {
  std::string out;
  size_t word = 0;
  bool data_uri = false;
  for (size_t i = 0; i < text.size(); i++) {
    char c = text[i];
    if (c == '\n' || c == '\r') {
      if (!out.empty() && out.back() != ' ') out += "; ";
      word = 0;
    } else if (c == ' ') {
      out += c;
      word = 0;
    } else {
      if (word++ == 0) data_uri = text.compare(i, 5, "data:") == 0;
      if (!data_uri || word <= 60)
        out += c;
      else if (word == 61)
        out += "...";
    }
  }
  while (!out.empty() && (out.back() == ' ' || out.back() == ';')) out.pop_back();
  return out.empty() ? std::string("unknown error") : out;
}

uint32_t read_u32le(const unsigned char *p) {
  return uint32_t(p[0]) | uint32_t(p[1]) << 8 | uint32_t(p[2]) << 16 | uint32_t(p[3]) << 24;
}

// Checks the GLB container before tinygltf sees it. tinygltf 2.7 forgets the 8-byte
// header of the BIN chunk when comparing its length with the file's, so a crafted file
// could make it read past the end of the data; the layout rules here are those of the
// glTF 2.0 specification, section 4.4 (binary glTF).
void check_glb(const unsigned char *bytes, size_t size) {
  if (size < 20)
    fail(BBC_ERR_GLTF, "GLB file of %zu bytes is shorter than its 20-byte header", size);
  uint32_t version = read_u32le(bytes + 4), length = read_u32le(bytes + 8);
  if (version != 2) fail(BBC_ERR_GLTF, "GLB container version %u is not 2", version);
  if (length > size)
    fail(BBC_ERR_GLTF, "GLB header says %u bytes but the file has %zu (truncated?)", length, size);
  uint64_t json_length = read_u32le(bytes + 12), json_type = read_u32le(bytes + 16);
  if (json_type != 0x4E4F534Au) fail(BBC_ERR_GLTF, "GLB file does not start with a JSON chunk");
  if (json_length == 0 || 20 + json_length > length)
    fail(BBC_ERR_GLTF, "GLB JSON chunk of %llu bytes does not fit in the file",
         (unsigned long long)json_length);
  uint64_t next = 20 + json_length;
  if (next < length) {
    if (next + 8 > length) fail(BBC_ERR_GLTF, "GLB BIN chunk header is truncated");
    uint64_t bin_length = read_u32le(bytes + next);
    if (next + 8 + bin_length > length)
      fail(BBC_ERR_GLTF, "GLB BIN chunk of %llu bytes does not fit in the file",
           (unsigned long long)bin_length);
  }
}

// Looks up extras.bbc of an object; NULL when absent or not an object.
const tinygltf::Value *bbc_extras(const tinygltf::Value &extras) {
  if (!extras.IsObject() || !extras.Has("bbc")) return nullptr;
  const tinygltf::Value &bbc = extras.Get("bbc");
  return bbc.IsObject() ? &bbc : nullptr;
}

// A number inside an extension object, with its default when absent.
double extension_number(const tinygltf::ExtensionMap &extensions, const char *extension,
                        const char *key, double fallback, const std::string &owner) {
  auto it = extensions.find(extension);
  if (it == extensions.end()) return fallback;
  if (!it->second.IsObject())
    fail(BBC_ERR_GLTF, "%s: %s is not a JSON object", owner.c_str(), extension);
  if (!it->second.Has(key)) return fallback;
  const tinygltf::Value &v = it->second.Get(key);
  if (!v.IsNumber()) fail(BBC_ERR_GLTF, "%s: %s.%s is not a number", owner.c_str(), extension, key);
  return v.GetNumberAsDouble();
}

// Three numbers inside an extension object, with their defaults when absent.
void extension_vec3(const tinygltf::ExtensionMap &extensions, const char *extension,
                    const char *key, const double fallback[3], const std::string &owner,
                    double out[3]) {
  for (int k = 0; k < 3; k++) out[k] = fallback[k];
  auto it = extensions.find(extension);
  if (it == extensions.end()) return;
  if (!it->second.IsObject())
    fail(BBC_ERR_GLTF, "%s: %s is not a JSON object", owner.c_str(), extension);
  if (!it->second.Has(key)) return;
  const tinygltf::Value &v = it->second.Get(key);
  if (!v.IsArray() || v.ArrayLen() != 3)
    fail(BBC_ERR_GLTF, "%s: %s.%s needs 3 numbers", owner.c_str(), extension, key);
  for (int k = 0; k < 3; k++) {
    const tinygltf::Value &x = v.Get(k);
    if (!x.IsNumber())
      fail(BBC_ERR_GLTF, "%s: %s.%s needs 3 numbers", owner.c_str(), extension, key);
    out[k] = x.GetNumberAsDouble();
  }
}

void identity(double m[16]) {
  for (int i = 0; i < 16; i++) m[i] = (i % 5 == 0) ? 1.0 : 0.0;
}

// c = a * b for column-major 4x4 matrices; c must not alias a or b.
void multiply(const double a[16], const double b[16], double c[16]) {
  for (int col = 0; col < 4; col++)
    for (int row = 0; row < 4; row++) {
      double s = 0.0;
      for (int k = 0; k < 4; k++) s += a[4 * k + row] * b[4 * col + k];
      c[4 * col + row] = s;
    }
}

class reader {
 public:
  reader(const tinygltf::Model &model, holder &out, const image_store &images)
      : model_(model), out_(out), store_(images) {}

  void run() {
    check_required_extensions();
    static const char *const asset_keys[] = {"light_units", nullptr};
    check_extras(model_.asset.extras, "asset", asset_keys);
    if (const tinygltf::Value *bbc = bbc_extras(model_.asset.extras))
      out_.view.light_units = string_key(*bbc, "light_units");
    static const char *const no_keys[] = {nullptr};
    for (size_t i = 0; i < model_.materials.size(); i++)
      check_extras(model_.materials[i].extras, label("material", i, model_.materials[i].name),
                   no_keys);
    for (size_t i = 0; i < model_.meshes.size(); i++)
      check_extras(model_.meshes[i].extras, label("mesh", i, model_.meshes[i].name), no_keys);
    // A sun's angular diameter is a property of the light (every node placing it shares
    // it, as they share its cone angles), read from the KHR light's own extras, where
    // Blender writes the light data's custom properties.
    static const char *const sun_keys[] = {"angular_diameter", nullptr};
    for (size_t i = 0; i < model_.lights.size(); i++)
      check_extras(model_.lights[i].extras, label("light", i, model_.lights[i].name),
                   model_.lights[i].type == "directional" ? sun_keys : no_keys);
    static const char *const camera_keys[] = {"width", "height", nullptr};
    for (size_t i = 0; i < model_.cameras.size(); i++)
      check_extras(model_.cameras[i].extras, label("camera", i, model_.cameras[i].name),
                   camera_keys);
    read_textures();
    for (size_t i = 0; i < model_.materials.size(); i++) read_material(i);

    if (model_.scenes.empty()) fail(BBC_ERR_SCENE, "the file has no scene");
    int scene = model_.defaultScene;
    if (scene == -1) {
      scene = 0;  // The specification leaves the choice to the loader; take the first.
    } else if (scene < 0 || size_t(scene) >= model_.scenes.size()) {
      fail(BBC_ERR_GLTF, "\"scene\" is %d but the file has %zu scenes", scene,
           model_.scenes.size());
    }
    find_animation_targets();
    walk(model_.scenes[size_t(scene)], scene);

    bbc__gltf_data &v = out_.view;
    v.primitive_count = uint32_t(out_.primitives.size());
    v.primitives = out_.primitives.empty() ? nullptr : out_.primitives.data();
    v.material_count = uint32_t(out_.materials.size());
    v.materials = out_.materials.empty() ? nullptr : out_.materials.data();
    v.light_count = uint32_t(out_.lights.size());
    v.lights = out_.lights.empty() ? nullptr : out_.lights.data();
    v.camera_count = uint32_t(out_.cameras.size());
    v.cameras = out_.cameras.empty() ? nullptr : out_.cameras.data();
    v.texture_count = uint32_t(out_.textures.size());
    v.textures = out_.textures.empty() ? nullptr : out_.textures.data();
    v.image_count = uint32_t(out_.images.size());
    v.images = out_.images.empty() ? nullptr : out_.images.data();
    v.animation_count = uint32_t(model_.animations.size());
    v.note_count = uint32_t(out_.notes.size());
    v.notes = out_.notes.empty() ? nullptr : out_.notes.data();
  }

 private:
  const tinygltf::Model &model_;
  holder &out_;
  const image_store &store_;
  // Vertex data of each (mesh, primitive) already read, so a mesh placed by several
  // nodes is copied once.
  std::map<std::pair<int, int>, bbc__gltf_primitive> cache_;
  // Each node's parent in the walk (-1 for a root), set as the walk reaches it.
  std::vector<int> parent_;
  // (node, path) -> (animation, channel) of the channels that move nodes, and the
  // channels already read (only those on the way to a camera are).
  std::map<std::pair<int, int>, std::pair<size_t, size_t>> targets_;
  std::map<std::pair<int, int>, const bbc__gltf_channel *> channels_;

  // Indexes the animation channels by the node property they move, checking their
  // references; their data is read only for the nodes above a camera.
  void find_animation_targets() {
    static const char *const paths[3] = {"translation", "rotation", "scale"};
    for (size_t a = 0; a < model_.animations.size(); a++) {
      const tinygltf::Animation &anim = model_.animations[a];
      for (size_t c = 0; c < anim.channels.size(); c++) {
        const tinygltf::AnimationChannel &ch = anim.channels[c];
        if (ch.sampler < 0 || size_t(ch.sampler) >= anim.samplers.size())
          fail(BBC_ERR_GLTF, "animation %zu channel %zu uses sampler %d, but it has %zu", a, c,
               ch.sampler, anim.samplers.size());
        if (ch.target_node < 0 || size_t(ch.target_node) >= model_.nodes.size())
          fail(BBC_ERR_GLTF, "animation %zu channel %zu targets node %d, but the file has %zu nodes",
               a, c, ch.target_node, model_.nodes.size());
        int path = -1;
        for (int k = 0; k < 3; k++)
          if (ch.target_path == paths[k]) path = k;
        if (path < 0) continue;  // "weights" (morph targets) do not move nodes
        auto key = std::make_pair(ch.target_node, path);
        if (targets_.count(key)) {
          note(label("node", size_t(ch.target_node), model_.nodes[size_t(ch.target_node)].name) +
               ": its " + paths[path] + " is animated twice; animation " +
               std::to_string(targets_[key].first) + " is used");
          continue;
        }
        targets_[key] = std::make_pair(a, c);
      }
    }
  }

  // The checked data of the channel moving (node, path), or NULL.
  const bbc__gltf_channel *channel(int node, int path) {
    auto key = std::make_pair(node, path);
    auto known = channels_.find(key);
    if (known != channels_.end()) return known->second;
    auto target = targets_.find(key);
    if (target == targets_.end()) return channels_[key] = nullptr;
    size_t a = target->second.first, c = target->second.second;
    const tinygltf::Animation &anim = model_.animations[a];
    const tinygltf::AnimationSampler &sampler =
        anim.samplers[size_t(anim.channels[c].sampler)];
    std::string what = "animation " + std::to_string(a) + " channel " + std::to_string(c);
    bbc__gltf_channel g{};
    g.path = path;
    if (sampler.interpolation == "LINEAR")
      g.interpolation = 0;
    else if (sampler.interpolation == "STEP")
      g.interpolation = 1;
    else if (sampler.interpolation == "CUBICSPLINE")
      g.interpolation = 2;
    else
      fail(BBC_ERR_GLTF, "%s: interpolation \"%s\" is not LINEAR, STEP or CUBICSPLINE",
           what.c_str(), sampler.interpolation.c_str());
    size_t keys = 0, values = 0;
    int components = path == 1 ? 4 : 3;
    g.times = floats(sampler.input, TINYGLTF_TYPE_SCALAR, 1, what + " input", &keys);
    g.values = floats(sampler.output, path == 1 ? TINYGLTF_TYPE_VEC4 : TINYGLTF_TYPE_VEC3,
                      components, what + " output", &values);
    size_t per_key = g.interpolation == 2 ? 3 : 1;
    if (keys == 0 || values != keys * per_key)
      fail(BBC_ERR_GLTF, "%s: %zu key times need %zu values, the output has %zu", what.c_str(),
           keys, keys * per_key, values);
    for (size_t k = 0; k < keys; k++)
      if (!std::isfinite(g.times[k]) || (k > 0 && !(g.times[k] > g.times[k - 1])))
        fail(BBC_ERR_GLTF, "%s: key times must be finite and strictly increasing (key %zu)",
             what.c_str(), k);
    for (size_t k = 0; k < values * size_t(components); k++)
      if (!std::isfinite(g.values[k]))
        fail(BBC_ERR_GLTF, "%s: value %zu is not finite", what.c_str(), k / size_t(components));
    g.key_count = uint32_t(keys);
    out_.channels.push_back(g);
    return channels_[key] = &out_.channels.back();
  }

  void check_required_extensions() {
    // The extensions bbc reads (KHR_texture_transform on base colour textures).
    static const char *const known[] = {
        "KHR_lights_punctual", "KHR_materials_transmission",      "KHR_materials_volume",
        "KHR_materials_ior",   "KHR_materials_emissive_strength", "KHR_texture_transform"};
    for (const std::string &name : model_.extensionsRequired) {
      bool ok = false;
      for (const char *k : known) ok = ok || name == k;
      if (!ok)
        fail(BBC_ERR_SCENE, "the file requires extension %s, which bbc does not support",
             name.c_str());
    }
  }

  // A string-valued key of an extras.bbc object: NULL when absent, "<not a string>"
  // when present with another JSON type.
  const char *string_key(const tinygltf::Value &bbc, const char *key) {
    if (!bbc.Has(key)) return nullptr;
    const tinygltf::Value &v = bbc.Get(key);
    return v.IsString() ? out_.keep(v.Get<std::string>()) : "<not a string>";
  }

  void note(const std::string &text) { out_.notes.push_back(out_.keep(text)); }

  // Notes extras that look meant for bbc but that bbc will not read: extras.bbc that
  // is not an object, a key of it not in `known` (NULL-terminated), and flat keys such
  // as "bbc.role" or "bbc_width" (what a custom property named so in Blender becomes).
  void check_extras(const tinygltf::Value &extras, const std::string &owner,
                    const char *const *known) {
    if (!extras.IsObject()) return;
    for (const std::string &key : extras.Keys()) {
      if (key == "bbc") {
        const tinygltf::Value &bbc = extras.Get(key);
        if (!bbc.IsObject()) {
          note(owner + ": extras.bbc is not a JSON object and is ignored (bbc reads objects " +
               "such as {\"bbc\": {\"role\": \"caster\"}})");
          continue;
        }
        for (const std::string &inner : bbc.Keys()) {
          bool ok = false;
          for (const char *const *k = known; *k; k++) ok = ok || inner == *k;
          if (ok) continue;
          std::string list;
          for (const char *const *k = known; *k; k++) list += std::string(list.empty() ? "" : ", ") + *k;
          note(owner + ": extras.bbc." + inner + " is not read here (" +
               (list.empty() ? std::string("bbc reads no settings here") : "bbc reads " + list) +
               ")");
        }
      } else if (key.size() > 3 && (key.compare(0, 3, "bbc") == 0 || key.compare(0, 3, "BBC") == 0) &&
                 (key[3] == '.' || key[3] == '_' || key[3] == ':' || key[3] == '-' ||
                  key[3] == '/')) {
        note(owner + ": extras key \"" + key + "\" is not read; bbc reads the object " +
             "extras.bbc, e.g. {\"bbc\": {\"" + key.substr(4) + "\": ...}}");
      }
    }
  }

  static std::string label(const char *kind, size_t index, const std::string &name) {
    std::string s = std::string(kind) + " " + std::to_string(index);
    if (!name.empty()) s += " (\"" + name + "\")";
    return s;
  }

  // Textures and their samplers, checked; images are listed, not yet decoded.
  void read_textures() {
    for (size_t i = 0; i < model_.images.size(); i++) {
      const tinygltf::Image &im = model_.images[i];
      bbc__gltf_image g{};
      g.name = out_.keep(!im.name.empty() ? im.name : im.uri);
      out_.images.push_back(g);
    }
    for (size_t i = 0; i < model_.textures.size(); i++) {
      const tinygltf::Texture &t = model_.textures[i];
      std::string owner = label("texture", i, t.name);
      bbc__gltf_texture g{};
      if (t.source < -1 || (t.source >= 0 && size_t(t.source) >= model_.images.size()))
        fail(BBC_ERR_GLTF, "%s: source %d, but the file has %zu images", owner.c_str(), t.source,
             model_.images.size());
      g.image = t.source;
      g.wrap_s = g.wrap_t = TINYGLTF_TEXTURE_WRAP_REPEAT;
      g.mag_filter = -1;
      if (t.sampler < -1 || (t.sampler >= 0 && size_t(t.sampler) >= model_.samplers.size()))
        fail(BBC_ERR_GLTF, "%s: sampler %d, but the file has %zu samplers", owner.c_str(),
             t.sampler, model_.samplers.size());
      if (t.sampler >= 0) {
        const tinygltf::Sampler &sm = model_.samplers[size_t(t.sampler)];
        g.wrap_s = sm.wrapS;
        g.wrap_t = sm.wrapT;
        g.mag_filter = sm.magFilter;
      }
      out_.textures.push_back(g);
    }
  }

  // Decodes image i (once) as RGBA; a failure is recorded in its `problem`.
  void decode_image(size_t i) {
    bbc__gltf_image &g = out_.images[i];
    if (g.rgba || g.problem) return;
    const tinygltf::Image &im = model_.images[i];
    auto problem = store_.problems.find(int(i));
    if (problem != store_.problems.end()) {
      g.problem = out_.keep(problem->second);
      return;
    }
    auto raw = store_.raw.find(int(i));
    if (raw == store_.raw.end()) {
      g.problem = out_.keep(im.uri.empty() ? std::string("it has no data")
                                           : "cannot read " + im.uri);
      return;
    }
    tinygltf::Image decoded;
    std::string err;
    // No user data: tinygltf's defaults, which expand every image to 4 channels.
    if (raw->second.size() > size_t(std::numeric_limits<int>::max()) ||
        !tinygltf::LoadImageData(&decoded, int(i), &err, nullptr, 0, 0, raw->second.data(),
                                 int(raw->second.size()), nullptr) ||
        decoded.component != 4 || (decoded.bits != 8 && decoded.bits != 16) ||
        decoded.width < 1 || decoded.height < 1 ||
        decoded.image.size() != size_t(decoded.width) * size_t(decoded.height) * 4 *
                                    size_t(decoded.bits / 8)) {
      g.problem = out_.keep("it cannot be decoded (" +
                            (err.empty() ? std::string("unexpected layout") : one_line(err)) +
                            ")");
      return;
    }
    out_.pixels.push_back(std::move(decoded.image));
    g.width = uint32_t(decoded.width);
    g.height = uint32_t(decoded.height);
    g.bits = decoded.bits;
    g.rgba = out_.pixels.back().data();
  }

  // A material's textureInfo with its KHR_texture_transform.
  bbc__gltf_texture_ref texture_ref(const tinygltf::TextureInfo &info, const std::string &owner,
                                    const char *slot) {
    bbc__gltf_texture_ref r{};
    r.texture = -1;
    r.scale[0] = r.scale[1] = 1.0;
    if (info.index == -1) return r;
    if (info.index < 0 || size_t(info.index) >= model_.textures.size())
      fail(BBC_ERR_GLTF, "%s: %s uses texture %d, but the file has %zu textures", owner.c_str(),
           slot, info.index, model_.textures.size());
    if (info.texCoord < 0)
      fail(BBC_ERR_GLTF, "%s: %s.texCoord %d is negative", owner.c_str(), slot, info.texCoord);
    r.texture = info.index;
    r.texcoord = info.texCoord;
    std::string what = owner + ": " + slot;
    auto it = info.extensions.find("KHR_texture_transform");
    if (it != info.extensions.end()) {
      const tinygltf::Value &x = it->second;
      if (!x.IsObject())
        fail(BBC_ERR_GLTF, "%s: KHR_texture_transform is not a JSON object", what.c_str());
      auto pair = [&](const char *key, double out[2]) {
        if (!x.Has(key)) return;
        const tinygltf::Value &v = x.Get(key);
        if (!v.IsArray() || v.ArrayLen() != 2 || !v.Get(0).IsNumber() || !v.Get(1).IsNumber())
          fail(BBC_ERR_GLTF, "%s: KHR_texture_transform.%s needs 2 numbers", what.c_str(), key);
        out[0] = v.Get(0).GetNumberAsDouble();
        out[1] = v.Get(1).GetNumberAsDouble();
      };
      pair("offset", r.offset);
      pair("scale", r.scale);
      if (x.Has("rotation")) {
        if (!x.Get("rotation").IsNumber())
          fail(BBC_ERR_GLTF, "%s: KHR_texture_transform.rotation is not a number", what.c_str());
        r.rotation = x.Get("rotation").GetNumberAsDouble();
      }
      if (x.Has("texCoord")) {
        const tinygltf::Value &v = x.Get("texCoord");
        if (!v.IsInt() || v.GetNumberAsInt() < 0)
          fail(BBC_ERR_GLTF, "%s: KHR_texture_transform.texCoord is not a non-negative integer",
               what.c_str());
        r.texcoord = v.GetNumberAsInt();
      }
      double all[5] = {r.offset[0], r.offset[1], r.scale[0], r.scale[1], r.rotation};
      for (double v : all)
        if (!std::isfinite(v))
          fail(BBC_ERR_GLTF, "%s: KHR_texture_transform has a non-finite value", what.c_str());
    }
    const bbc__gltf_texture &t = out_.textures[size_t(r.texture)];
    if (t.image >= 0) decode_image(size_t(t.image));
    return r;
  }

  // A textureInfo inside a material extension (tinygltf parses only the core ones), as
  // texture_ref reads it.
  bbc__gltf_texture_ref extension_texture(const tinygltf::ExtensionMap &extensions,
                                          const char *extension, const char *key,
                                          const std::string &owner) {
    tinygltf::TextureInfo info;
    auto it = extensions.find(extension);
    std::string slot = std::string(extension) + "." + key;
    if (it != extensions.end() && it->second.IsObject() && it->second.Has(key)) {
      const tinygltf::Value &v = it->second.Get(key);
      if (!v.IsObject() || !v.Has("index") || !v.Get("index").IsInt())
        fail(BBC_ERR_GLTF, "%s: %s is not a textureInfo with an integer index", owner.c_str(),
             slot.c_str());
      info.index = v.Get("index").GetNumberAsInt();
      if (info.index == -1) info.index = -2;  // -1 means "none" to texture_ref
      if (v.Has("texCoord")) {
        if (!v.Get("texCoord").IsInt())
          fail(BBC_ERR_GLTF, "%s: %s.texCoord is not an integer", owner.c_str(), slot.c_str());
        info.texCoord = v.Get("texCoord").GetNumberAsInt();
      }
      if (v.Has("extensions") && v.Get("extensions").IsObject()) {
        const tinygltf::Value &x = v.Get("extensions");
        for (const std::string &name : x.Keys()) info.extensions[name] = x.Get(name);
      }
    }
    return texture_ref(info, owner, slot.c_str());
  }

  void read_material(size_t i) {
    const tinygltf::Material &m = model_.materials[i];
    std::string owner = label("material", i, m.name);
    bbc__gltf_material g{};
    g.name = out_.keep(m.name);
    const std::vector<double> &bc = m.pbrMetallicRoughness.baseColorFactor;
    if (bc.size() != 4) fail(BBC_ERR_GLTF, "%s: baseColorFactor needs 4 numbers", owner.c_str());
    for (int k = 0; k < 4; k++) g.base_color[k] = bc[size_t(k)];
    g.metallic = m.pbrMetallicRoughness.metallicFactor;
    g.roughness = m.pbrMetallicRoughness.roughnessFactor;
    if (m.emissiveFactor.size() != 3)
      fail(BBC_ERR_GLTF, "%s: emissiveFactor needs 3 numbers", owner.c_str());
    for (int k = 0; k < 3; k++) g.emissive[k] = m.emissiveFactor[size_t(k)];
    g.transmission = extension_number(m.extensions, "KHR_materials_transmission",
                                      "transmissionFactor", 0.0, owner);
    g.thickness =
        extension_number(m.extensions, "KHR_materials_volume", "thicknessFactor", 0.0, owner);
    static const double white[3] = {1.0, 1.0, 1.0};
    extension_vec3(m.extensions, "KHR_materials_volume", "attenuationColor", white, owner,
                   g.attenuation_color);
    g.attenuation_distance = extension_number(m.extensions, "KHR_materials_volume",
                                              "attenuationDistance", INFINITY, owner);
    g.ior = extension_number(m.extensions, "KHR_materials_ior", "ior", 1.5, owner);
    g.emissive_strength = extension_number(m.extensions, "KHR_materials_emissive_strength",
                                           "emissiveStrength", 1.0, owner);
    g.base_color_texture =
        texture_ref(m.pbrMetallicRoughness.baseColorTexture, owner, "baseColorTexture");
    g.metallic_roughness_texture = texture_ref(m.pbrMetallicRoughness.metallicRoughnessTexture,
                                               owner, "metallicRoughnessTexture");
    g.transmission_texture = extension_texture(m.extensions, "KHR_materials_transmission",
                                               "transmissionTexture", owner);
    g.emissive_texture = texture_ref(m.emissiveTexture, owner, "emissiveTexture");
    // glTF 2.0, section 5.19 (material): alphaMode is one of three strings, alphaCutoff
    // a number >= 0 (tinygltf fills in OPAQUE and 0.5 when they are absent).
    if (m.alphaMode == "OPAQUE")
      g.alpha_mode = BBC_ALPHA_OPAQUE;
    else if (m.alphaMode == "MASK")
      g.alpha_mode = BBC_ALPHA_MASK;
    else if (m.alphaMode == "BLEND")
      g.alpha_mode = BBC_ALPHA_BLEND;
    else
      fail(BBC_ERR_GLTF, "%s: alphaMode \"%s\" is not OPAQUE, MASK or BLEND", owner.c_str(),
           m.alphaMode.c_str());
    g.alpha_cutoff = m.alphaCutoff;
    if (!std::isfinite(g.alpha_cutoff) || g.alpha_cutoff < 0.0)
      fail(BBC_ERR_GLTF, "%s: alphaCutoff %g is not a number >= 0", owner.c_str(), g.alpha_cutoff);
    out_.materials.push_back(g);
  }

  // The node's local transform: its "matrix" (has_matrix), else its T, R (unit
  // quaternion x, y, z, w) and S, with the defaults of glTF 2.0, section 3.5.3.
  static void local_transform(const tinygltf::Node &n, size_t index, bbc__gltf_node_motion *out) {
    if (!n.matrix.empty()) {
      if (n.matrix.size() != 16) fail(BBC_ERR_GLTF, "node %zu: matrix needs 16 numbers", index);
      out->has_matrix = 1;
      for (int i = 0; i < 16; i++) out->matrix[i] = n.matrix[size_t(i)];
      return;
    }
    double *t = out->translation, *s = out->scale, *q = out->rotation;
    t[0] = t[1] = t[2] = 0.0;
    s[0] = s[1] = s[2] = 1.0;
    q[0] = q[1] = q[2] = 0.0;
    q[3] = 1.0;
    if (!n.translation.empty()) {
      if (n.translation.size() != 3)
        fail(BBC_ERR_GLTF, "node %zu: translation needs 3 numbers", index);
      for (int i = 0; i < 3; i++) t[i] = n.translation[size_t(i)];
    }
    if (!n.scale.empty()) {
      if (n.scale.size() != 3) fail(BBC_ERR_GLTF, "node %zu: scale needs 3 numbers", index);
      for (int i = 0; i < 3; i++) s[i] = n.scale[size_t(i)];
    }
    if (!n.rotation.empty()) {
      if (n.rotation.size() != 4) fail(BBC_ERR_GLTF, "node %zu: rotation needs 4 numbers", index);
      double len = 0.0;
      for (int i = 0; i < 4; i++) len += n.rotation[size_t(i)] * n.rotation[size_t(i)];
      len = std::sqrt(len);
      // Writers round unit quaternions to a few digits; renormalising keeps the
      // rotation orthonormal instead of letting the rounding scale the mesh.
      if (!(len > 0.5 && len < 2.0))
        fail(BBC_ERR_GLTF, "node %zu: rotation is not a unit quaternion", index);
      for (int i = 0; i < 4; i++) q[i] = n.rotation[size_t(i)] / len;
    }
  }

  static void local_matrix(const tinygltf::Node &n, size_t index, double m[16]) {
    bbc__gltf_node_motion t{};
    local_transform(n, index, &t);
    if (t.has_matrix)
      memcpy(m, t.matrix, sizeof t.matrix);
    else
      bbc__trs_matrix(t.translation, t.rotation, t.scale, m);
  }

  // Depth first, roots in order, a node before its children, with an explicit stack so
  // that a deep hierarchy cannot overflow the C stack.
  void walk(const tinygltf::Scene &scene, int scene_index) {
    struct item {
      int node;
      int parent;  // -1 for a root
      double parent_world[16];
    };
    std::vector<item> stack;
    std::vector<char> visited(model_.nodes.size(), 0);
    parent_.assign(model_.nodes.size(), -1);
    for (size_t i = scene.nodes.size(); i-- > 0;) {
      item it;
      it.node = scene.nodes[i];
      it.parent = -1;
      identity(it.parent_world);
      stack.push_back(it);
    }
    while (!stack.empty()) {
      item it = stack.back();
      stack.pop_back();
      if (it.node < 0 || size_t(it.node) >= model_.nodes.size()) {
        if (it.parent < 0)
          fail(BBC_ERR_GLTF, "scene %d lists node %d, but the file has %zu nodes", scene_index,
               it.node, model_.nodes.size());
        fail(BBC_ERR_GLTF, "node %d has child %d, but the file has %zu nodes", it.parent, it.node,
             model_.nodes.size());
      }
      size_t index = size_t(it.node);
      if (visited[index])
        fail(BBC_ERR_GLTF, "node %zu is reached twice; the node hierarchy must be a tree", index);
      visited[index] = 1;
      parent_[index] = it.parent;
      const tinygltf::Node &n = model_.nodes[index];
      double local[16], world[16];
      local_matrix(n, index, local);
      multiply(it.parent_world, local, world);
      visit(n, index, world);
      for (size_t c = n.children.size(); c-- > 0;) {
        item child;
        child.node = n.children[c];
        child.parent = it.node;
        memcpy(child.parent_world, world, sizeof world);
        stack.push_back(child);
      }
    }
  }

  void visit(const tinygltf::Node &n, size_t index, const double world[16]) {
    static const char *const mesh_node_keys[] = {"role", nullptr};
    static const char *const camera_node_keys[] = {"role", "width", "height", nullptr};
    check_extras(n.extras, label("node", index, n.name),
                 n.camera >= 0 ? camera_node_keys : mesh_node_keys);
    const tinygltf::Value *bbc = bbc_extras(n.extras);
    if (n.mesh >= 0) {
      if (size_t(n.mesh) >= model_.meshes.size())
        fail(BBC_ERR_GLTF, "node %zu uses mesh %d, but the file has %zu meshes", index, n.mesh,
             model_.meshes.size());
      const char *role = bbc ? string_key(*bbc, "role") : nullptr;
      const tinygltf::Mesh &mesh = model_.meshes[size_t(n.mesh)];
      for (size_t p = 0; p < mesh.primitives.size(); p++) {
        bbc__gltf_primitive g = primitive(n.mesh, int(p));
        memcpy(g.world, world, sizeof g.world);
        g.node_name = out_.keep(n.name);
        g.node_index = uint32_t(index);
        g.role = role;
        if (out_.primitives.size() >= UINT32_MAX)
          fail(BBC_ERR_SCENE, "the scene has too many primitives");
        out_.primitives.push_back(g);
      }
    } else if (n.mesh < -1) {
      fail(BBC_ERR_GLTF, "node %zu uses mesh %d", index, n.mesh);
    }

    if (n.camera >= 0 || n.camera < -1) {
      if (n.camera < 0 || size_t(n.camera) >= model_.cameras.size())
        fail(BBC_ERR_GLTF, "node %zu uses camera %d, but the file has %zu cameras", index, n.camera,
             model_.cameras.size());
      camera(n, index, world, bbc);
    }

    auto ext = n.extensions.find("KHR_lights_punctual");
    if (ext != n.extensions.end()) {
      const tinygltf::Value &v = ext->second;
      if (!v.IsObject() || !v.Has("light") || !v.Get("light").IsInt())
        fail(BBC_ERR_GLTF, "node %zu: KHR_lights_punctual needs an integer \"light\"", index);
      int light = v.Get("light").GetNumberAsInt();
      if (light < 0 || size_t(light) >= model_.lights.size())
        fail(BBC_ERR_GLTF, "node %zu uses light %d, but the file has %zu lights", index, light,
             model_.lights.size());
      const tinygltf::Light &l = model_.lights[size_t(light)];
      bbc__gltf_light g{};
      g.name = out_.keep(!l.name.empty() ? l.name : n.name);
      g.type = out_.keep(l.type);
      g.node_index = uint32_t(index);
      for (int k = 0; k < 3; k++) g.position[k] = world[12 + k];
      for (int k = 0; k < 3; k++) g.direction[k] = -world[8 + k];
      g.inner_cone = l.spot.innerConeAngle;
      g.outer_cone = l.spot.outerConeAngle;
      if (l.color.empty()) {
        g.color[0] = g.color[1] = g.color[2] = 1.0;
      } else if (l.color.size() == 3) {
        for (int k = 0; k < 3; k++) g.color[k] = l.color[size_t(k)];
      } else {
        fail(BBC_ERR_GLTF, "light %d: color needs 3 numbers", light);
      }
      g.intensity = l.intensity;
      const tinygltf::Value *light_bbc = bbc_extras(l.extras);
      if (l.type == "directional" && light_bbc && light_bbc->Has("angular_diameter")) {
        const tinygltf::Value &v = light_bbc->Get("angular_diameter");
        if (v.IsNumber()) {
          g.has_angular_diameter = 1;
          g.angular_diameter = v.GetNumberAsDouble();
        } else {
          note(label("light", size_t(light), l.name) +
               ": extras.bbc.angular_diameter is not a number and is ignored" +
               (v.IsString() ? " (it is the string \"" + v.Get<std::string>() + "\")" : ""));
        }
      }
      out_.lights.push_back(g);
    }
  }

  void camera(const tinygltf::Node &n, size_t index, const double world[16],
              const tinygltf::Value *bbc) {
    const tinygltf::Camera &c = model_.cameras[size_t(n.camera)];
    if (out_.cameras.size() >= UINT32_MAX) fail(BBC_ERR_SCENE, "the scene has too many cameras");
    out_.cameras.emplace_back();
    bbc__gltf_camera &g = out_.cameras.back();
    g = bbc__gltf_camera{};
    // The nodes from the root down to this one, each with what animates it.
    std::vector<int> chain;
    for (int k = int(index); k >= 0; k = parent_[size_t(k)]) chain.push_back(k);
    out_.paths.emplace_back(chain.size());
    std::vector<bbc__gltf_node_motion> &path = out_.paths.back();
    for (size_t k = 0; k < chain.size(); k++) {
      int node = chain[chain.size() - 1 - k];
      bbc__gltf_node_motion &m = path[k];
      m.node_index = uint32_t(node);
      local_transform(model_.nodes[size_t(node)], size_t(node), &m);
      for (int p = 0; p < 3; p++) {
        m.channels[p] = channel(node, p);
        if (m.channels[p] && m.has_matrix)
          fail(BBC_ERR_GLTF, "node %d has a matrix and is animated, which glTF forbids", node);
        g.animated |= m.channels[p] != nullptr;
      }
    }
    g.path_length = uint32_t(path.size());
    g.path = path.data();
    g.name = out_.keep(!c.name.empty() ? c.name : n.name);
    g.type = out_.keep(c.type);
    g.node_index = uint32_t(index);
    memcpy(g.world, world, sizeof g.world);
    g.yfov = c.perspective.yfov;
    g.aspect_ratio = c.perspective.aspectRatio;
    const char *keys[2] = {"width", "height"};
    int *has[2] = {&g.has_width, &g.has_height};
    double *value[2] = {&g.width, &g.height};
    const tinygltf::Value *camera_bbc = bbc_extras(c.extras);
    for (int k = 0; k < 2; k++) {
      const tinygltf::Value *from = bbc && bbc->Has(keys[k]) ? bbc
                                    : camera_bbc && camera_bbc->Has(keys[k]) ? camera_bbc
                                                                             : nullptr;
      if (!from) continue;
      const tinygltf::Value &v = from->Get(keys[k]);
      if (v.IsNumber()) {
        *has[k] = 1;
        *value[k] = v.GetNumberAsDouble();
      } else {
        note(label(from == bbc ? "node" : "camera", from == bbc ? index : size_t(n.camera),
                   from == bbc ? n.name : c.name) +
             ": extras.bbc." + keys[k] + " is not a number and is ignored" +
             (v.IsString() ? " (it is the string \"" + v.Get<std::string>() + "\")" : ""));
      }
    }
  }

  struct span {
    const unsigned char *data;  // first element
    size_t stride;              // bytes from one element to the next
    size_t count;
    int component_type;
  };

  // Resolves an accessor to bytes inside its buffer, checking every reference and
  // that the last element ends inside both its buffer view and its buffer.
  span resolve(int accessor, int type, const std::string &what) {
    if (accessor < 0 || size_t(accessor) >= model_.accessors.size())
      fail(BBC_ERR_GLTF, "%s refers to accessor %d, but the file has %zu accessors", what.c_str(),
           accessor, model_.accessors.size());
    const tinygltf::Accessor &a = model_.accessors[size_t(accessor)];
    if (a.sparse.isSparse)
      fail(BBC_ERR_SCENE, "%s: accessor %d is sparse, which bbc does not support", what.c_str(),
           accessor);
    if (a.bufferView < 0)
      fail(BBC_ERR_SCENE, "%s: accessor %d has no bufferView, which bbc does not support",
           what.c_str(), accessor);
    if (size_t(a.bufferView) >= model_.bufferViews.size())
      fail(BBC_ERR_GLTF, "accessor %d refers to bufferView %d, but the file has %zu", accessor,
           a.bufferView, model_.bufferViews.size());
    if (a.type != type)
      fail(BBC_ERR_GLTF, "%s: accessor %d has the wrong type", what.c_str(), accessor);
    const tinygltf::BufferView &bv = model_.bufferViews[size_t(a.bufferView)];
    if (bv.buffer < 0 || size_t(bv.buffer) >= model_.buffers.size())
      fail(BBC_ERR_GLTF, "bufferView %d refers to buffer %d, but the file has %zu", a.bufferView,
           bv.buffer, model_.buffers.size());
    const std::vector<unsigned char> &buffer = model_.buffers[size_t(bv.buffer)].data;
    if (bv.byteOffset > buffer.size() || bv.byteLength > buffer.size() - bv.byteOffset)
      fail(BBC_ERR_GLTF,
           "bufferView %d (offset %zu, length %zu) lies outside buffer %d of %zu bytes",
           a.bufferView, bv.byteOffset, bv.byteLength, bv.buffer, buffer.size());

    int component = tinygltf::GetComponentSizeInBytes(uint32_t(a.componentType));
    int components = tinygltf::GetNumComponentsInType(uint32_t(a.type));
    if (component <= 0 || components <= 0)
      fail(BBC_ERR_GLTF, "accessor %d has an invalid component type", accessor);
    size_t element = size_t(component) * size_t(components);
    size_t stride = bv.byteStride ? bv.byteStride : element;
    if (stride < element)
      fail(BBC_ERR_GLTF, "bufferView %d: byteStride %zu is smaller than an element (%zu)",
           a.bufferView, bv.byteStride, element);
    span s{nullptr, stride, a.count, a.componentType};
    if (a.count > UINT32_MAX)
      fail(BBC_ERR_SCENE, "accessor %d has more than 2^32-1 elements", accessor);
    if (a.count == 0) return s;
    size_t room = bv.byteLength;
    if (a.byteOffset > room || element > room - a.byteOffset ||
        a.count - 1 > (room - a.byteOffset - element) / stride)
      fail(BBC_ERR_GLTF,
           "accessor %d (offset %zu, %zu elements of %zu bytes, stride %zu) does not fit in "
           "bufferView %d of %zu bytes",
           accessor, a.byteOffset, a.count, element, stride, a.bufferView, bv.byteLength);
    s.data = buffer.data() + bv.byteOffset + a.byteOffset;
    return s;
  }

  const float *floats(int accessor, int type, int components, const std::string &what,
                      size_t *count) {
    span s = resolve(accessor, type, what);
    if (s.component_type != TINYGLTF_COMPONENT_TYPE_FLOAT)
      fail(BBC_ERR_SCENE,
           "%s: accessor %d has componentType %d; bbc reads only float (5126) attributes",
           what.c_str(), accessor, s.component_type);
    *count = s.count;
    if (s.count == 0) return nullptr;
    out_.floats.emplace_back(s.count * size_t(components));
    std::vector<float> &v = out_.floats.back();
    // memcpy, because nothing guarantees that the elements are aligned.
    for (size_t i = 0; i < s.count; i++)
      memcpy(&v[i * size_t(components)], s.data + i * s.stride, sizeof(float) * size_t(components));
    return v.data();
  }

  const uint32_t *index_array(int accessor, uint32_t vertex_count, const std::string &what,
                              uint32_t *count) {
    span s = resolve(accessor, TINYGLTF_TYPE_SCALAR, what);
    size_t size;
    switch (s.component_type) {
      case TINYGLTF_COMPONENT_TYPE_UNSIGNED_BYTE:
        size = 1;
        break;
      case TINYGLTF_COMPONENT_TYPE_UNSIGNED_SHORT:
        size = 2;
        break;
      case TINYGLTF_COMPONENT_TYPE_UNSIGNED_INT:
        size = 4;
        break;
      default:
        fail(BBC_ERR_GLTF,
             "%s: indices have componentType %d; glTF allows only unsigned "
             "8, 16 or 32-bit integers",
             what.c_str(), s.component_type);
    }
    *count = uint32_t(s.count);
    if (s.count == 0) return nullptr;
    out_.indices.emplace_back(s.count);
    std::vector<uint32_t> &v = out_.indices.back();
    for (size_t i = 0; i < s.count; i++) {
      const unsigned char *p = s.data + i * s.stride;
      uint32_t x;
      if (size == 1) {
        x = p[0];
      } else if (size == 2) {
        uint16_t h;
        memcpy(&h, p, 2);
        x = h;
      } else {
        memcpy(&x, p, 4);
      }
      if (x >= vertex_count)
        fail(BBC_ERR_GLTF, "%s: index %u at position %zu is out of range (%u vertices)",
             what.c_str(), x, i, vertex_count);
      v[i] = x;
    }
    return v.data();
  }

  bbc__gltf_primitive primitive(int mesh_index, int prim_index) {
    auto cached = cache_.find({mesh_index, prim_index});
    if (cached != cache_.end()) return cached->second;

    const tinygltf::Mesh &mesh = model_.meshes[size_t(mesh_index)];
    const tinygltf::Primitive &p = mesh.primitives[size_t(prim_index)];
    std::string what =
        label("mesh", size_t(mesh_index), mesh.name) + " primitive " + std::to_string(prim_index);
    bbc__gltf_primitive g{};
    g.mesh_name = out_.keep(mesh.name);
    g.mesh_index = uint32_t(mesh_index);
    g.primitive_index = uint32_t(prim_index);
    g.mode = p.mode == -1 ? TINYGLTF_MODE_TRIANGLES : p.mode;
    if (p.material < -1 || (p.material >= 0 && size_t(p.material) >= model_.materials.size()))
      fail(BBC_ERR_GLTF, "%s uses material %d, but the file has %zu materials", what.c_str(),
           p.material, model_.materials.size());
    g.material = p.material;

    auto position = p.attributes.find("POSITION");
    if (position == p.attributes.end())
      fail(BBC_ERR_SCENE, "%s has no POSITION attribute", what.c_str());
    size_t n = 0;
    g.positions = floats(position->second, TINYGLTF_TYPE_VEC3, 3, what + " POSITION", &n);
    g.vertex_count = uint32_t(n);
    auto normal = p.attributes.find("NORMAL");
    if (normal != p.attributes.end()) {
      size_t m = 0;
      g.normals = floats(normal->second, TINYGLTF_TYPE_VEC3, 3, what + " NORMAL", &m);
      if (m != n)
        fail(BBC_ERR_GLTF, "%s: NORMAL has %zu elements but POSITION has %zu", what.c_str(), m, n);
    }
    auto uv = p.attributes.find("TEXCOORD_0");
    if (uv != p.attributes.end()) {
      size_t m = 0;
      g.uvs = floats(uv->second, TINYGLTF_TYPE_VEC2, 2, what + " TEXCOORD_0", &m);
      if (m != n)
        fail(BBC_ERR_GLTF, "%s: TEXCOORD_0 has %zu elements but POSITION has %zu", what.c_str(), m,
             n);
    }
    if (p.indices >= 0) {
      g.indices = index_array(p.indices, g.vertex_count, what + " indices", &g.index_count);
    } else if (p.indices < -1) {
      fail(BBC_ERR_GLTF, "%s refers to accessor %d for its indices", what.c_str(), p.indices);
    } else if (n > 0) {
      // A non-indexed primitive uses its vertices in order.
      out_.indices.emplace_back(n);
      std::vector<uint32_t> &v = out_.indices.back();
      for (size_t i = 0; i < n; i++) v[i] = uint32_t(i);
      g.indices = v.data();
      g.index_count = uint32_t(n);
    }
    cache_[{mesh_index, prim_index}] = g;
    return g;
  }
};

// Copies at most size-1 bytes of a printf-style message, turning control characters
// (names from the file may hold any) into '?' so the message stays on one line.
void report(const bbc__gltf_options *options, bbc_result code, const char *name,
            const char *message) {
  if (!options || !options->error_fn) return;
  char line[1024];
  snprintf(line, sizeof line, "%s: %s", name, message);
  for (char *c = line; *c; c++)
    if ((unsigned char)*c < 0x20 || *c == 0x7f) *c = '?';
  options->error_fn(options->user, code, line);
}

void parse(holder &h, const unsigned char *bytes, size_t size, const char *base_dir) {
  if (size > std::numeric_limits<unsigned int>::max())
    fail(BBC_ERR_GLTF, "the file is larger than 4 GiB, the limit of glTF");
  bool binary = size >= 4 && memcmp(bytes, "glTF", 4) == 0;
  if (binary) check_glb(bytes, size);

  fs_context fs;
  fs.allowed = base_dir != nullptr;
  if (base_dir) fs.base_dir = *base_dir ? base_dir : ".";
  tinygltf::TinyGLTF loader;
  tinygltf::Model model;
  image_store images;
  images.model = &model;
  loader.SetImageLoader(keep_image, &images);
  loader.SetFsCallbacks(tinygltf::FsCallbacks{fs_file_exists, fs_expand_file_path,
                                              fs_read_whole_file, fs_write_whole_file, &fs});
  std::string err, warn;
  bool ok =
      binary
          ? loader.LoadBinaryFromMemory(&model, &err, &warn, bytes, unsigned(size), fs.base_dir)
          : loader.LoadASCIIFromString(&model, &err, &warn, reinterpret_cast<const char *>(bytes),
                                       unsigned(size), fs.base_dir);
  // tinygltf's warnings all concern images, whose problems the reader reports itself
  // for the images it uses, so they are dropped.
  if (!ok) fail(BBC_ERR_GLTF, "invalid glTF: %s", one_line(err).c_str());
  reader(model, h, images).run();
}

bbc_result guarded(bbc__gltf_data **out, const unsigned char *bytes, size_t size, const char *name,
                   const char *base_dir, const bbc__gltf_options *options) {
  try {
    std::unique_ptr<holder> h(new holder());
    h->view.internal = h.get();
    parse(*h, bytes, size, base_dir);
    *out = &h.release()->view;
    return BBC_OK;
  } catch (const failure &f) {
    report(options, f.code, name, f.message.c_str());
    return f.code;
  } catch (const std::bad_alloc &) {
    report(options, BBC_ERR_OUT_OF_MEMORY, name, "out of memory while reading glTF");
    return BBC_ERR_OUT_OF_MEMORY;
  } catch (const std::exception &e) {
    char message[768];
    snprintf(message, sizeof message, "invalid glTF: %s", e.what());
    report(options, BBC_ERR_GLTF, name, message);
    return BBC_ERR_GLTF;
  } catch (...) {
    report(options, BBC_ERR_GLTF, name, "invalid glTF (unknown exception in the parser)");
    return BBC_ERR_GLTF;
  }
}

}  // namespace

extern "C" bbc_result bbc__gltf_parse_memory(bbc__gltf_data **out, const void *bytes, size_t size,
                                             const char *name, const char *base_dir,
                                             const bbc__gltf_options *options) {
  if (out) *out = nullptr;
  if (!name) name = "(memory)";
  if (!out || (!bytes && size > 0)) {
    report(options, BBC_ERR_INVALID_ARGUMENT, name, "no output or no data given");
    return BBC_ERR_INVALID_ARGUMENT;
  }
  static const unsigned char empty = 0;
  return guarded(out, bytes ? static_cast<const unsigned char *>(bytes) : &empty, size, name,
                 base_dir, options);
}

extern "C" bbc_result bbc__gltf_parse(bbc__gltf_data **out, const char *path,
                                      const bbc__gltf_options *options) {
  if (out) *out = nullptr;
  if (!out || !path) {
    report(options, BBC_ERR_INVALID_ARGUMENT, path ? path : "(null)", "no output or no path given");
    return BBC_ERR_INVALID_ARGUMENT;
  }
  try {
    std::vector<unsigned char> bytes;
    std::string why;
    if (!read_whole_file(path, &bytes, &why)) {
      std::string message = "cannot read: " + why;
      report(options, BBC_ERR_IO, path, message.c_str());
      return BBC_ERR_IO;
    }
    // Buffers are looked up in the file's folder ("." for a bare file name).
    std::string p(path);
    size_t slash = p.find_last_of('/');
    std::string base = slash == std::string::npos ? std::string(".") : p.substr(0, slash + 1);
    return guarded(out, bytes.data(), bytes.size(), path, base.c_str(), options);
  } catch (const std::bad_alloc &) {
    report(options, BBC_ERR_OUT_OF_MEMORY, path, "out of memory while reading the file");
    return BBC_ERR_OUT_OF_MEMORY;
  } catch (...) {
    report(options, BBC_ERR_IO, path, "cannot read the file");
    return BBC_ERR_IO;
  }
}

extern "C" void bbc__gltf_free(bbc__gltf_data *data) {
  if (data) delete static_cast<holder *>(data->internal);
}
