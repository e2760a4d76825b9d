// OpenGL 3.3 core entry points through GLVND's libOpenGL (works with GLX
// windows and EGL surfaceless contexts alike). Only the UI thread touches GL.
#pragma once

#ifndef GL_GLEXT_PROTOTYPES
#define GL_GLEXT_PROTOTYPES 1
#endif
#include <GL/gl.h>
#include <GL/glext.h>
