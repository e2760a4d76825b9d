#include "ui/gl_image.h"

#include <deque>
#include <string>

#include "core/log.h"
#include "ui/gl.h"

namespace vsl::ui {

FloatTexture::~FloatTexture() {
  if (tex_) glDeleteTextures(1, &tex_);
}

void FloatTexture::upload(const Image& image) {
  if (!tex_) glGenTextures(1, &tex_);
  glBindTexture(GL_TEXTURE_2D, tex_);
  glPixelStorei(GL_UNPACK_ALIGNMENT, 4);
  glPixelStorei(GL_UNPACK_ROW_LENGTH, 0);
  if (image.width != width_ || image.height != height_) {
    glTexParameteri(GL_TEXTURE_2D, GL_TEXTURE_MIN_FILTER, GL_NEAREST);
    glTexParameteri(GL_TEXTURE_2D, GL_TEXTURE_MAG_FILTER, GL_NEAREST);
    glTexParameteri(GL_TEXTURE_2D, GL_TEXTURE_WRAP_S, GL_CLAMP_TO_EDGE);
    glTexParameteri(GL_TEXTURE_2D, GL_TEXTURE_WRAP_T, GL_CLAMP_TO_EDGE);
    glTexImage2D(GL_TEXTURE_2D, 0, GL_RGB32F, image.width, image.height, 0, GL_RGB, GL_FLOAT, image.rgb.data());
    width_ = image.width;
    height_ = image.height;
  } else {
    glTexSubImage2D(GL_TEXTURE_2D, 0, 0, 0, image.width, image.height, GL_RGB, GL_FLOAT, image.rgb.data());
  }
}

namespace {

GLuint gProgram = 0;
GLint gProj = -1, gMode = -1, gScale = -1, gTex = -1;
bool gFailed = false;
std::deque<DisplayParams> gParams;  // alive until the frame is rendered

const char* kFragment = R"(
in vec2 Frag_UV;
out vec4 Out_Color;
uniform sampler2D Texture;
uniform int Mode;
uniform float Scale;
vec3 falseColour(float t) {
  // Must match core/compare.cpp falseColour(): black, blue, magenta, yellow, white.
  t = clamp(t, 0.0, 1.0);
  vec3 s0 = vec3(0.0), s1 = vec3(0.1, 0.1, 0.8), s2 = vec3(0.85, 0.1, 0.6), s3 = vec3(1.0, 0.85, 0.1), s4 = vec3(1.0);
  float x = t * 4.0;
  if (x < 1.0) return mix(s0, s1, x);
  if (x < 2.0) return mix(s1, s2, x - 1.0);
  if (x < 3.0) return mix(s2, s3, x - 2.0);
  return mix(s3, s4, min(x - 3.0, 1.0));
}
vec3 magma(float t) {
  // Must match core/flip.cpp magma(): every 16th entry (and the last) of
  // matplotlib's 256-entry table, linear in between.
  const vec3 stops[17] = vec3[17](
      vec3(0.001462, 0.000466, 0.013866), vec3(0.039608, 0.031090, 0.133515), vec3(0.113094, 0.065492, 0.276784),
      vec3(0.211718, 0.061992, 0.418647), vec3(0.316654, 0.071690, 0.485380), vec3(0.414709, 0.110431, 0.504662),
      vec3(0.512831, 0.148179, 0.507648), vec3(0.613617, 0.181811, 0.498536), vec3(0.716387, 0.214982, 0.475290),
      vec3(0.816914, 0.255895, 0.436461), vec3(0.904281, 0.319610, 0.388137), vec3(0.960949, 0.418323, 0.359630),
      vec3(0.986700, 0.535582, 0.382210), vec3(0.996096, 0.653659, 0.446213), vec3(0.996898, 0.769591, 0.534892),
      vec3(0.992440, 0.884330, 0.640099), vec3(0.987053, 0.991438, 0.749504));
  float x = clamp(t, 0.0, 1.0) * 255.0;
  int i = min(int(x / 16.0), 15);
  float x0 = 16.0 * float(i), x1 = i == 15 ? 255.0 : 16.0 * float(i + 1);
  return mix(stops[i], stops[i + 1], (x - x0) / (x1 - x0));
}
float srgb(float v) {
  v = clamp(v, 0.0, 1.0);
  return v <= 0.0031308 ? 12.92 * v : 1.055 * pow(v, 1.0 / 2.4) - 0.055;
}
// Must match ui/studio.cpp acesFilmic(): Narkowicz 2015's ACES fit, 0.6 pre-scale.
vec3 aces(vec3 x) {
  x *= 0.6;
  return clamp(x * (2.51 * x + 0.03) / (x * (2.43 * x + 0.59) + 0.14), 0.0, 1.0);
}
void main() {
  vec3 c = texture(Texture, Frag_UV).rgb;
  if (Mode == 0 || Mode == 4) {
    c *= Scale;
    if (Mode == 4) c = aces(c);
    Out_Color = vec4(srgb(c.r), srgb(c.g), srgb(c.b), 1.0);
  } else if (Mode == 5) {
    // Must match ui/studio.cpp toneMapPixel(): log10 luminance over [-3, 1].
    float lum = dot(c * Scale, vec3(0.2126, 0.7152, 0.0722));
    Out_Color = vec4(falseColour(lum > 0.0 ? (log(lum) / log(10.0) + 3.0) / 4.0 : 0.0), 1.0);
  } else if (Mode == 1) {
    float v = (c.r + c.g + c.b) / 3.0 * Scale;
    Out_Color = vec4(falseColour(v), 1.0);
  } else if (Mode == 3) {
    float v = (c.r + c.g + c.b) / 3.0 * Scale;
    Out_Color = vec4(magma(v), 1.0);
  } else {
    float v = clamp((c.r + c.g + c.b) / 3.0 * Scale, -1.0, 1.0);
    vec3 col = v < 0.0 ? mix(vec3(1.0), vec3(0.15, 0.35, 1.0), -v) : mix(vec3(1.0), vec3(1.0, 0.2, 0.1), v);
    Out_Color = vec4(col, 1.0);
  }
}
)";

const char* kVertex = R"(
in vec2 Position;
in vec2 UV;
in vec4 Color;
uniform mat4 ProjMtx;
out vec2 Frag_UV;
void main() {
  Frag_UV = UV;
  gl_Position = ProjMtx * vec4(Position.xy, 0, 1);
}
)";

GLuint compile(GLenum type, const char* src) {
  GLuint s = glCreateShader(type);
  const char* parts[2] = {"#version 330 core\n", src};
  glShaderSource(s, 2, parts, nullptr);
  glCompileShader(s);
  GLint ok = 0;
  glGetShaderiv(s, GL_COMPILE_STATUS, &ok);
  if (!ok) {
    char buf[2048];
    glGetShaderInfoLog(s, sizeof buf, nullptr, buf);
    log::error(std::string("display shader: ") + buf);
  }
  return s;
}

// Links the display program with the same attribute locations as the ImGui
// backend's program (which is bound when our callback runs), so the backend's
// vertex layout feeds our shader unchanged.
bool ensureProgram() {
  if (gProgram || gFailed) return gProgram != 0;
  GLint backend = 0;
  glGetIntegerv(GL_CURRENT_PROGRAM, &backend);
  GLuint vs = compile(GL_VERTEX_SHADER, kVertex), fs = compile(GL_FRAGMENT_SHADER, kFragment);
  GLuint p = glCreateProgram();
  glAttachShader(p, vs);
  glAttachShader(p, fs);
  for (const char* a : {"Position", "UV", "Color"}) {
    GLint loc = backend ? glGetAttribLocation(GLuint(backend), a) : -1;
    if (loc >= 0) glBindAttribLocation(p, GLuint(loc), a);
  }
  glLinkProgram(p);
  glDeleteShader(vs);
  glDeleteShader(fs);
  GLint ok = 0;
  glGetProgramiv(p, GL_LINK_STATUS, &ok);
  if (!ok) {
    char buf[2048];
    glGetProgramInfoLog(p, sizeof buf, nullptr, buf);
    log::error(std::string("display shader link: ") + buf);
    glDeleteProgram(p);
    gFailed = true;
    return false;
  }
  gProgram = p;
  gProj = glGetUniformLocation(p, "ProjMtx");
  gMode = glGetUniformLocation(p, "Mode");
  gScale = glGetUniformLocation(p, "Scale");
  gTex = glGetUniformLocation(p, "Texture");
  return true;
}

void useDisplayProgram(const ImDrawList*, const ImDrawCmd* cmd) {
  if (!ensureProgram()) return;
  const DisplayParams* p = static_cast<const DisplayParams*>(cmd->UserCallbackData);
  ImDrawData* dd = ImGui::GetDrawData();
  float L = dd->DisplayPos.x, R = dd->DisplayPos.x + dd->DisplaySize.x;
  float T = dd->DisplayPos.y, B = dd->DisplayPos.y + dd->DisplaySize.y;
  const float ortho[16] = {2.0f / (R - L),    0, 0, 0, 0, 2.0f / (T - B), 0, 0, 0, 0, -1, 0, (R + L) / (L - R),
                           (T + B) / (B - T), 0, 1};
  glUseProgram(gProgram);
  glUniformMatrix4fv(gProj, 1, GL_FALSE, ortho);
  glUniform1i(gMode, int(p->mode));
  glUniform1f(gScale, p->scale);
  glUniform1i(gTex, 0);
}

}  // namespace

void beginFrame() { gParams.clear(); }

void drawImage(ImDrawList* list, const FloatTexture& tex, ImVec2 p0, ImVec2 p1, ImVec2 uv0, ImVec2 uv1,
               const DisplayParams& params) {
  if (!tex.valid()) return;
  gParams.push_back(params);
  list->AddCallback(useDisplayProgram, &gParams.back());
  list->AddImage(tex.id(), p0, p1, uv0, uv1);
  list->AddCallback(ImDrawCallback_ResetRenderState, nullptr);
}

void shutdown() {
  if (gProgram) glDeleteProgram(gProgram);
  gProgram = 0;
}

}  // namespace vsl::ui
