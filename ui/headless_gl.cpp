#include "ui/headless_gl.h"

#include <EGL/egl.h>
#include <EGL/eglext.h>

#include "ui/gl.h"

namespace vsl::ui {

HeadlessGL::~HeadlessGL() {
  if (display_) {
    EGLDisplay dpy = static_cast<EGLDisplay>(display_);
    if (fbo_) glDeleteFramebuffers(1, &fbo_);
    if (color_) glDeleteRenderbuffers(1, &color_);
    eglMakeCurrent(dpy, EGL_NO_SURFACE, EGL_NO_SURFACE, EGL_NO_CONTEXT);
    if (context_) eglDestroyContext(dpy, static_cast<EGLContext>(context_));
    eglTerminate(dpy);
  }
}

Result<void> HeadlessGL::init(int width, int height) {
  auto fail = [&](const std::string& m) -> Result<void> {
    return Error(m + " (EGL error 0x" + std::to_string(eglGetError()) + ")");
  };
  auto getPlatformDisplay =
      reinterpret_cast<PFNEGLGETPLATFORMDISPLAYEXTPROC>(eglGetProcAddress("eglGetPlatformDisplayEXT"));
  EGLDisplay dpy = getPlatformDisplay ? getPlatformDisplay(EGL_PLATFORM_SURFACELESS_MESA, EGL_DEFAULT_DISPLAY, nullptr)
                                      : EGL_NO_DISPLAY;
  if (dpy == EGL_NO_DISPLAY) return fail("EGL: no surfaceless display (is Mesa's EGL installed?)");
  EGLint major = 0, minor = 0;
  if (!eglInitialize(dpy, &major, &minor)) return fail("EGL: eglInitialize failed");
  display_ = dpy;
  if (!eglBindAPI(EGL_OPENGL_API)) return fail("EGL: OpenGL API not available");
  const EGLint attribs[] = {
      EGL_CONTEXT_MAJOR_VERSION,           3,       EGL_CONTEXT_MINOR_VERSION, 3, EGL_CONTEXT_OPENGL_PROFILE_MASK,
      EGL_CONTEXT_OPENGL_CORE_PROFILE_BIT, EGL_NONE};
  EGLContext ctx = eglCreateContext(dpy, EGL_NO_CONFIG_KHR, EGL_NO_CONTEXT, attribs);
  if (ctx == EGL_NO_CONTEXT) return fail("EGL: cannot create an OpenGL 3.3 core context");
  context_ = ctx;
  if (!eglMakeCurrent(dpy, EGL_NO_SURFACE, EGL_NO_SURFACE, ctx)) return fail("EGL: eglMakeCurrent failed");
  width_ = width;
  height_ = height;
  glGenFramebuffers(1, &fbo_);
  glGenRenderbuffers(1, &color_);
  glBindRenderbuffer(GL_RENDERBUFFER, color_);
  glRenderbufferStorage(GL_RENDERBUFFER, GL_RGBA8, width, height);
  glBindFramebuffer(GL_FRAMEBUFFER, fbo_);
  glFramebufferRenderbuffer(GL_FRAMEBUFFER, GL_COLOR_ATTACHMENT0, GL_RENDERBUFFER, color_);
  if (glCheckFramebufferStatus(GL_FRAMEBUFFER) != GL_FRAMEBUFFER_COMPLETE)
    return Error("OpenGL: the framebuffer object is incomplete");
  glViewport(0, 0, width, height);
  return {};
}

void HeadlessGL::bind() const {
  glBindFramebuffer(GL_FRAMEBUFFER, fbo_);
  glViewport(0, 0, width_, height_);
}

std::vector<uint8_t> HeadlessGL::readPixels() const {
  bind();
  return readFramebuffer(0, 0, width_, height_, height_);
}

std::vector<uint8_t> readFramebuffer(int x, int y, int w, int h, int framebufferHeight) {
  std::vector<uint8_t> rgba(size_t(w) * h * 4), rgb(size_t(w) * h * 3);
  glPixelStorei(GL_PACK_ALIGNMENT, 1);
  glReadPixels(x, framebufferHeight - y - h, w, h, GL_RGBA, GL_UNSIGNED_BYTE, rgba.data());
  for (int r = 0; r < h; ++r)  // GL's rows start at the bottom
    for (int c = 0; c < w; ++c)
      for (int k = 0; k < 3; ++k) rgb[(size_t(r) * w + c) * 3 + k] = rgba[(size_t(h - 1 - r) * w + c) * 4 + k];
  return rgb;
}

}  // namespace vsl::ui
