"""tetbench's VTK peer: one of VTK's unstructured-grid volume mappers behind the peer protocol,
written with the Python SDK (tetbench_peer). `vtk_peer.py MAPPER`, MAPPER = pt | raycast |
zsweep. tetbench (algorithms/src/render/vtk.rs) writes this file and the SDK into the peer's
private directory and starts it there under TETBENCH_VTK_PYTHON.

The scene and camera arrive in the contract's terms and are made VTK's here (docs/vtk.md):
zero-volume cells are dropped (VTK's Bunyk ray caster crashes on them), the transfer function
becomes a colour and an opacity node at every point with opacity tau / tau_max and unit distance
L / tau_max, and the ray-cast and ZSweep mappers' camera is widened (and, for the ray caster,
shifted) so that their ray image is read exactly at tetbench's pixel centres.
"""

import math
import sys
import time

import numpy as np

from tetbench_peer import Frame, Peer, serve


def rays_across(size, isd):
    """Rays across `size` pixels at sample distance `isd`, as VTK computes it (in float)."""
    return int(np.float32(size) / np.float32(isd))


def aligned_isd(w):
    """The largest float sample distance that gives 2W + 1 rays across W pixels."""
    target = 2 * w + 1
    isd = np.float32(w) / np.float32(target)
    while rays_across(w, isd) < target:
        isd = np.nextafter(isd, np.float32(0))
    return isd


class VtkPeer(Peer):
    version = "1.0"
    projections = ("ortho", "persp")

    def __init__(self, mapper):
        if mapper not in ("pt", "raycast", "zsweep"):
            raise SystemExit(f"vtk_peer.py: unknown mapper {mapper!r} (pt, raycast, zsweep)")
        self.kind = mapper
        self.name = "vtk-" + mapper
        self.family = "pt" if mapper == "pt" else "raycasting"
        self.integrators = ("average",) if mapper == "pt" else ("preint", "partial")
        self.window = None
        self.size = None
        self.dropped = 0

    def hello(self, msg):
        """Imports VTK and opens the offscreen (EGL, else OSMesa) window."""
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
        device = f"vtk {vtkVersion.GetVTKVersion()} / {renderer} / {window.GetClassName()}"
        return {"device": device}

    # -- set-up --------------------------------------------------------------------------------

    def prepare(self, scene):
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

        self.grid_mode = scene.params.get("grid", "vtk")
        if self.grid_mode not in ("vtk", "aligned"):
            raise ValueError(f"grid={self.grid_mode}: expected vtk or aligned")
        pts = scene.positions
        length = scene.diagonal
        # Cells with zero volume (|V| < 1e-14 L^3) hold no optical depth; VTK's Bunyk ray caster
        # crashes on them.
        tets = scene.cells.astype(np.int64)
        e = pts[tets[:, 1:]] - pts[tets[:, :1]]
        vol = np.linalg.det(e) / 6.0
        keep = ~((np.abs(vol) < 1e-14 * length * length * length) | (vol == 0.0))
        self.dropped = int((~keep).sum())
        tets = tets[keep]

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
        scalars = numpy_to_vtk(np.ascontiguousarray(scene.scalars), deep=1)
        scalars.SetName("s")
        grid.GetPointData().SetScalars(scalars)

        # Colour and opacity carry a node at every transfer-function point (VTK's ray-cast
        # integrators read opacity only at colour nodes), both clamped beyond the ends. Our
        # tau (per normalised length) becomes opacity tau / tau_max with unit distance
        # L / tau_max, so VTK's attenuation (opacity per unit distance) is tau / L.
        tf = scene.tf
        tau_max = float(tf.tau.max()) if len(tf.tau) else 0.0
        if tau_max > 0.0 and length > 0.0:
            norm, unit = 1.0 / tau_max, length / tau_max
        else:
            norm, unit = 0.0, max(length, sys.float_info.min)
        color = vtkColorTransferFunction()
        opacity = vtkPiecewiseFunction()
        for s, rgb, tau in zip(tf.s, tf.rgb, tf.tau):
            color.AddRGBPoint(float(s), *(float(c) for c in rgb))
            opacity.AddPoint(float(s), min(float(tau) * norm, 1.0))
        color.ClampingOn()
        opacity.ClampingOn()
        prop = vtkVolumeProperty()
        prop.SetColor(color)
        prop.SetScalarOpacity(opacity)
        prop.SetScalarOpacityUnitDistance(unit)
        prop.SetInterpolationTypeToLinear()
        prop.ShadeOff()

        if self.kind == "pt":
            mapper = vtkProjectedTetrahedraMapper()
        else:
            mapper = (
                vtkUnstructuredGridVolumeRayCastMapper()
                if self.kind == "raycast"
                else vtkUnstructuredGridVolumeZSweepMapper()
            )
            mapper.SetAutoAdjustSampleDistances(0)
            if scene.integrator == "preint":
                mapper.SetRayIntegrator(vtkUnstructuredGridPreIntegration())
            else:
                mapper.SetRayIntegrator(vtkUnstructuredGridPartialPreIntegration())
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

        old = self.window.GetRenderers().GetFirstRenderer()
        if old is not None:
            self.window.RemoveRenderer(old)
        self.window.AddRenderer(ren)
        self.ren, self.fb, self.mapper, self.grid = ren, fb, mapper, grid
        # VTK's first render (the PT mapper's draws nothing) belongs to set-up: a 64x64 ortho
        # frame from view (0, 0).
        r = max(0.5 * length, sys.float_info.min)
        warm = {
            "width": 64, "height": 64, "projection": "ortho",
            "eye": [0.0, 0.0, 2.0 * r], "up": [0.0, 1.0, 0.0],
            "radius": r, "pixel_size": 2.0 * r / 64,
        }
        self.set_camera(self.vtk_camera(warm)[0])
        self.window.Render()
        self.size = (64, 64)

    def prepare_counters(self):
        return {"dropped_cells": self.dropped}

    # -- frames --------------------------------------------------------------------------------

    def vtk_camera(self, c):
        """The contract's camera in VTK's terms, and the ray count (docs/vtk.md, "Camera")."""
        w, h = max(int(c["width"]), 1), max(int(c["height"]), 1)
        r = max(float(c["radius"]), sys.float_info.min)
        half_h = 0.5 * h * float(c["pixel_size"])
        if self.kind == "pt" or self.grid_mode == "vtk":
            isd, nx, ny = np.float32(1.0), w, h
        else:
            isd = aligned_isd(w)
            nx, ny = rays_across(w, isd), rays_across(h, isd)
        # Ray grids: widen by N/(N-1); the ray caster's rays sit at k/N, so it is also shifted
        # by half a sample; ZSweep's sit at (k + 1/2)/N and need no shift.
        nxf, nyf = float(max(nx, 2)), float(max(ny, 2))
        if self.kind == "pt":
            scale, center = 1.0, [0.0, 0.0]
        elif self.kind == "raycast":
            scale, center = nyf / (nyf - 1.0), [1.0 / nxf, 1.0 / nyf]
        else:
            scale, center = nyf / (nyf - 1.0), [0.0, 0.0]
        half_v = half_h * scale
        if c["projection"] == "ortho":
            parallel, angle, clip = True, 0.0, [0.25 * r, 3.75 * r]
        else:
            parallel, clip = False, [0.5 * r, 4.5 * r]
            angle = 2.0 * math.atan(half_v / (3.0 * r)) * (180.0 / math.pi)
        cam = {
            "width": w, "height": h,
            "position": [float(x) for x in c["eye"]],
            "view_up": [float(x) for x in c["up"]],
            "parallel": parallel,
            "parallel_scale": half_v,
            "view_angle": angle,
            "window_center": center,
            "clipping_range": clip,
            "image_sample_distance": float(isd),
        }
        return cam, nx * ny

    def set_camera(self, c):
        w, h = c["width"], c["height"]
        if list(self.window.GetSize()) != [w, h]:
            self.window.SetSize(w, h)
        if self.kind != "pt":
            self.mapper.SetImageSampleDistance(c["image_sample_distance"])
        cam = self.ren.GetActiveCamera()
        cam.SetFocalPoint(0.0, 0.0, 0.0)
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

    def render(self, camera):
        msg = {
            "width": camera.width, "height": camera.height, "projection": camera.projection,
            "eye": camera.eye, "up": camera.up, "radius": camera.radius,
            "pixel_size": camera.pixel_size,
        }
        c, rays = self.vtk_camera(msg)
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
        counters = {"warmup_ms": warm_ms}
        if self.kind != "pt":
            counters["rays"] = rays
        # OpenGL's row 0 is the bottom; tetbench's is the top.
        return Frame(
            img[::-1],
            draw_ms=(t1 - t0) * 1e3,
            readback_ms=(t2 - t1) * 1e3,
            counters=counters,
        )


if __name__ == "__main__":
    serve(VtkPeer(sys.argv[1] if len(sys.argv) > 1 else ""))
