"""tetbench's VTK peer: runs one of VTK's unstructured-grid volume mappers on a scene that
tetbench hands over, and sends back a float RGBA image with VTK's own frame times.

Started by algorithms/src/render/vtk.rs as `PYTHON vtk_peer.py DIR` (the Rust side writes this
file into DIR from the copy compiled into the binary). Protocol: one JSON object per line on
stdin, one JSON reply per line on the original stdout (VTK's own messages go to stderr). Bulk
data travels as little-endian raw files in DIR:

  prepare: points.f64 (n x 3, already centred on the bounding box), scalars.f64 (n, the transfer
           function's s), tets.i64 (m x 4, zero-volume cells already dropped). The message has
           the mapper, the integrator, the transfer-function nodes (s, rgb, opacity) and the
           opacity unit distance.
  render:  the camera in VTK's terms (computed by the Rust side from tetbench's camera), the
           image size and the image sample distance; the reply's image is image.f32 (H x W x 4,
           row 0 at the top, premultiplied, as tetbench's images are).

Every reply carries `peak_rss_bytes`, the peak resident set of this process.
"""

import json
import os
import resource
import sys
import time
import traceback


def peak_rss_bytes():
    # ru_maxrss is in KiB on Linux.
    return resource.getrusage(resource.RUSAGE_SELF).ru_maxrss * 1024


class Peer:
    def __init__(self, workdir):
        self.dir = workdir
        self.vtk = None
        self.window = None
        self.size = None

    # -- set-up ------------------------------------------------------------------------------

    def hello(self, _msg):
        """Imports VTK and opens the offscreen (EGL, else OSMesa) window."""
        t0 = time.perf_counter()
        import numpy  # noqa: F401  (checked here so that a missing numpy is one clear line)
        from vtkmodules.vtkCommonCore import vtkVersion

        import vtkmodules.vtkRenderingOpenGL2 as gl2
        import vtkmodules.vtkRenderingVolumeOpenGL2  # noqa: F401  (registers the GL mappers)

        window = None
        errors = []
        for cls in ("vtkEGLRenderWindow", "vtkOSOpenGLRenderWindow"):
            make = getattr(gl2, cls, None)
            if make is None:
                errors.append(f"{cls}: not in this VTK build")
                continue
            try:
                w = make()
                w.SetOffScreenRendering(1)
                w.SetSize(8, 8)
                w.Render()
                if not w.SupportsOpenGL():
                    errors.append(f"{cls}: no OpenGL context")
                    continue
                window = w
                break
            except Exception as e:  # pragma: no cover - depends on the machine
                errors.append(f"{cls}: {e}")
        if window is None:
            raise RuntimeError("no offscreen OpenGL window (" + "; ".join(errors) + ")")
        caps = window.ReportCapabilities() or ""
        renderer = ""
        for line in caps.splitlines():
            if "renderer string" in line:
                renderer = line.split(":", 1)[1].strip()
        self.window = window
        self.window_class = window.GetClassName()
        return {
            "vtk": vtkVersion.GetVTKVersion(),
            "gl": renderer,
            "window": self.window_class,
            "import_ms": (time.perf_counter() - t0) * 1e3,
        }

    def prepare(self, msg):
        import numpy as np
        from vtkmodules.util.numpy_support import numpy_to_vtk, numpy_to_vtkIdTypeArray
        from vtkmodules.vtkCommonCore import vtkPoints
        from vtkmodules.vtkCommonDataModel import (
            VTK_TETRA,
            vtkCellArray,
            vtkPiecewiseFunction,
            vtkUnstructuredGrid,
        )
        from vtkmodules.vtkRenderingCore import (
            vtkColorTransferFunction,
            vtkRenderer,
            vtkVolume,
            vtkVolumeProperty,
        )
        from vtkmodules.vtkRenderingOpenGL2 import (
            vtkCameraPass,
            vtkFramebufferPass,
            vtkOpaquePass,
            vtkRenderPassCollection,
            vtkSequencePass,
            vtkTextureObject,
            vtkVolumetricPass,
        )
        from vtkmodules.vtkRenderingVolume import (
            vtkProjectedTetrahedraMapper,
            vtkUnstructuredGridPartialPreIntegration,
            vtkUnstructuredGridPreIntegration,
            vtkUnstructuredGridVolumeRayCastMapper,
            vtkUnstructuredGridVolumeZSweepMapper,
        )

        t0 = time.perf_counter()
        d = self.dir
        pts = np.fromfile(os.path.join(d, "points.f64"), dtype="<f8").reshape(-1, 3)
        s = np.fromfile(os.path.join(d, "scalars.f64"), dtype="<f8")
        tets = np.fromfile(os.path.join(d, "tets.i64"), dtype="<i8").reshape(-1, 4)

        grid = vtkUnstructuredGrid()
        points = vtkPoints()
        points.SetData(numpy_to_vtk(np.ascontiguousarray(pts), deep=1))
        grid.SetPoints(points)
        cells = vtkCellArray()
        offsets = np.arange(0, 4 * len(tets) + 1, 4, dtype=np.int64)
        cells.SetData(
            numpy_to_vtkIdTypeArray(offsets, deep=1),
            numpy_to_vtkIdTypeArray(np.ascontiguousarray(tets).ravel(), deep=1),
        )
        grid.SetCells(VTK_TETRA, cells)
        scalars = numpy_to_vtk(np.ascontiguousarray(s), deep=1)
        scalars.SetName("s")
        grid.GetPointData().SetScalars(scalars)

        # Colour and opacity carry a node at every transfer-function point (VTK's ray-cast
        # integrators read opacity only at colour nodes), both clamped beyond the ends.
        color = vtkColorTransferFunction()
        opacity = vtkPiecewiseFunction()
        for p in msg["tf"]:
            color.AddRGBPoint(p["s"], *p["rgb"])
            opacity.AddPoint(p["s"], p["opacity"])
        color.ClampingOn()
        opacity.ClampingOn()
        prop = vtkVolumeProperty()
        prop.SetColor(color)
        prop.SetScalarOpacity(opacity)
        prop.SetScalarOpacityUnitDistance(msg["unit_distance"])
        prop.SetInterpolationTypeToLinear()
        prop.ShadeOff()

        kind = msg["mapper"]
        if kind == "pt":
            mapper = vtkProjectedTetrahedraMapper()
        elif kind in ("raycast", "zsweep"):
            mapper = (
                vtkUnstructuredGridVolumeRayCastMapper()
                if kind == "raycast"
                else vtkUnstructuredGridVolumeZSweepMapper()
            )
            mapper.SetAutoAdjustSampleDistances(0)
            integ = msg["integrator"]
            if integ == "preint":
                mapper.SetRayIntegrator(vtkUnstructuredGridPreIntegration())
            elif integ == "partial":
                mapper.SetRayIntegrator(vtkUnstructuredGridPartialPreIntegration())
            else:
                raise ValueError(f"unknown integrator {integ}")
        else:
            raise ValueError(f"unknown mapper {kind}")
        mapper.SetInputData(grid)
        volume = vtkVolume()
        volume.SetMapper(mapper)
        volume.SetProperty(prop)

        ren = vtkRenderer()
        ren.SetBackground(0.0, 0.0, 0.0)
        ren.SetBackgroundAlpha(0.0)
        ren.AddVolume(volume)
        # Render into a float colour target (the window's own framebuffer is 8-bit); the depth
        # target must be Fixed24, or the PT mapper draws nothing.
        passes = vtkRenderPassCollection()
        passes.AddItem(vtkOpaquePass())
        passes.AddItem(vtkVolumetricPass())
        seq = vtkSequencePass()
        seq.SetPasses(passes)
        cam_pass = vtkCameraPass()
        cam_pass.SetDelegatePass(seq)
        fb = vtkFramebufferPass()
        fb.SetColorFormat(vtkTextureObject.Float32)
        fb.SetDepthFormat(vtkTextureObject.Fixed24)
        fb.SetDelegatePass(cam_pass)
        ren.SetPass(fb)

        if self.window is not None:
            old = self.window.GetRenderers().GetFirstRenderer()
            if old is not None:
                self.window.RemoveRenderer(old)
        self.window.AddRenderer(ren)
        self.ren, self.fb, self.mapper, self.kind = ren, fb, mapper, kind
        self.grid = grid
        self.size = None
        build_ms = (time.perf_counter() - t0) * 1e3
        # VTK's first render (the PT mapper's draws nothing) belongs to set-up.
        t1 = time.perf_counter()
        self.set_camera(msg["warmup"])
        self.window.Render()
        self.size = (msg["warmup"]["width"], msg["warmup"]["height"])
        return {
            "build_ms": build_ms,
            "first_render_ms": (time.perf_counter() - t1) * 1e3,
        }

    # -- frames ------------------------------------------------------------------------------

    def set_camera(self, c):
        w, h = c["width"], c["height"]
        if self.window.GetSize() != (w, h) and list(self.window.GetSize()) != [w, h]:
            self.window.SetSize(w, h)
        if self.kind != "pt":
            self.mapper.SetImageSampleDistance(c["image_sample_distance"])
        cam = self.ren.GetActiveCamera()
        cam.SetFocalPoint(*c["focal_point"])
        cam.SetPosition(*c["position"])
        cam.SetViewUp(*c["view_up"])
        if c["parallel"]:
            cam.ParallelProjectionOn()
            cam.SetParallelScale(c["parallel_scale"])
        else:
            cam.ParallelProjectionOff()
            cam.SetViewAngle(c["view_angle"])
        cam.SetWindowCenter(*c["window_center"])
        cam.SetClippingRange(*c["clipping_range"])

    def render(self, msg):
        import numpy as np

        c = msg["camera"]
        w, h = c["width"], c["height"]
        self.set_camera(c)
        warm_ms = 0.0
        if self.size != (w, h):
            # A new size builds new targets: render once untimed, as at set-up.
            t = time.perf_counter()
            self.window.Render()
            warm_ms = (time.perf_counter() - t) * 1e3
            self.size = (w, h)
        t0 = time.perf_counter()
        self.window.Render()
        t1 = time.perf_counter()
        tex = self.fb.GetColorTexture()
        if tex.GetWidth() != w or tex.GetHeight() != h:
            raise RuntimeError(
                f"colour target is {tex.GetWidth()}x{tex.GetHeight()}, expected {w}x{h}"
            )
        pbo = tex.Download()
        img = np.zeros((h, w, 4), dtype=np.float32)
        if not pbo.Download2D(10, img, [w, h], 4, [0, 0]):  # 10 = VTK_FLOAT
            raise RuntimeError("reading the float colour target failed")
        t2 = time.perf_counter()
        # OpenGL's row 0 is the bottom; tetbench's is the top.
        np.ascontiguousarray(img[::-1]).tofile(os.path.join(self.dir, "image.f32"))
        return {
            "draw_ms": (t1 - t0) * 1e3,
            "readback_ms": (t2 - t1) * 1e3,
            "warmup_ms": warm_ms,
        }


def main():
    workdir = sys.argv[1]
    # Keep the protocol channel private: VTK (C++) may print to fd 1, so point fd 1 at stderr.
    proto = os.fdopen(os.dup(1), "w", buffering=1)
    os.dup2(2, 1)
    sys.stdout = sys.stderr
    peer = Peer(workdir)
    handlers = {"hello": peer.hello, "prepare": peer.prepare, "render": peer.render}
    for line in sys.stdin:
        line = line.strip()
        if not line:
            continue
        try:
            msg = json.loads(line)
            if msg.get("cmd") == "quit":
                break
            reply = handlers[msg["cmd"]](msg)
            reply["ok"] = True
        except Exception as e:
            traceback.print_exc(file=sys.stderr)
            reply = {"ok": False, "error": f"{type(e).__name__}: {e}".replace("\n", " ")}
        reply["peak_rss_bytes"] = peak_rss_bytes()
        proto.write(json.dumps(reply) + "\n")
        proto.flush()


if __name__ == "__main__":
    main()
