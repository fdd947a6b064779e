"""choreo.preview.gl: which offscreen OpenGL back-end renders, and remembering the one that
worked so that the next process need not try them again."""

from __future__ import annotations

from concurrent.futures import ThreadPoolExecutor

import mujoco
import pytest

from choreo.errors import PreviewError
from choreo.preview import gl
from choreo.preview.render import FrameRenderer
from choreo.robot import check_cache


@pytest.fixture
def cache(tmp_path, monkeypatch):
    """An empty cache of this test's own, and a process whose PyOpenGL platform is not fixed
    yet (a test in this process may have rendered before): the trials are what runs."""
    monkeypatch.setenv("CHOREO_CACHE_DIR", str(tmp_path / "cache"))
    monkeypatch.delenv("PYOPENGL_PLATFORM", raising=False)
    return tmp_path / "cache" / gl.REMEMBERED


def in_a_new_thread(function, *args):
    """``function(*args)`` in a thread that has no GL context kept from an earlier render."""
    with ThreadPoolExecutor(1) as pool:
        return pool.submit(function, *args).result()


def trials(monkeypatch, works: tuple[str, ...]) -> list[str]:
    """The back-ends tried from now on, in order; those in ``works`` work."""
    tried: list[str] = []
    monkeypatch.setattr(
        gl,
        "backend_problem",
        lambda b: tried.append(b) or (None if b in works else f"no {b} here"),
    )
    return tried


def test_an_offscreen_backend_works_on_this_machine():
    backend = gl.offscreen_backend()
    assert backend in ("egl", "osmesa")
    assert gl.backend_problem(backend) is None


def test_egl_is_preferred_and_osmesa_is_the_fallback(monkeypatch, cache):
    monkeypatch.setenv("MUJOCO_GL", "")
    tried = []
    monkeypatch.setattr(
        gl,
        "backend_problem",
        lambda b: tried.append(b) or ("no EGL device" if b == "egl" else None),
    )
    assert gl.choose_backend() == "osmesa"
    assert tried == ["egl", "osmesa"]


def test_no_working_backend_fails_saying_what_to_install(monkeypatch, cache):
    monkeypatch.setenv("MUJOCO_GL", "")
    monkeypatch.setattr(gl, "backend_problem", lambda backend: f"{backend} library missing")
    with pytest.raises(PreviewError, match="egl: egl library missing; osmesa: .*libosmesa6"):
        gl.choose_backend()


def test_mujoco_gl_in_the_environment_is_used_without_trying_others(monkeypatch):
    monkeypatch.setenv("MUJOCO_GL", "osmesa")
    monkeypatch.setattr(gl, "backend_problem", lambda backend: pytest.fail("tried"))
    assert gl.choose_backend() == "osmesa"


@pytest.mark.parametrize("value", ["glfw", " GLFW "])
def test_glfw_named_is_used_without_trying_others(monkeypatch, value):
    monkeypatch.setenv("MUJOCO_GL", value)
    monkeypatch.setattr(gl, "backend_problem", lambda backend: pytest.fail("tried"))
    assert gl.choose_backend() == "glfw"


def test_a_mujoco_gl_that_names_no_backend_is_refused_naming_the_valid_ones(monkeypatch):
    monkeypatch.setenv("MUJOCO_GL", "bogus")
    monkeypatch.setattr(gl, "backend_problem", lambda backend: pytest.fail("tried"))
    with pytest.raises(PreviewError) as raised:
        gl.choose_backend()
    assert str(raised.value) == (
        "MUJOCO_GL=bogus is not an OpenGL back-end to render with: set it to egl, osmesa or "
        "glfw, or unset it to use the first that works"
    )


def test_glfw_without_a_window_system_is_one_error(monkeypatch):
    monkeypatch.setattr(gl, "window_system_problem", lambda: "no display")
    with pytest.raises(PreviewError) as raised:
        gl.context_class("glfw")
    assert str(raised.value) == (
        "cannot render with glfw: no display; unset MUJOCO_GL to render with egl or osmesa"
    )


# --- the back-end that worked, remembered ------------------------------------------------------


def test_the_backend_that_worked_is_remembered_and_not_tried_again(monkeypatch, cache):
    monkeypatch.setenv("MUJOCO_GL", "")
    tried = trials(monkeypatch, works=("osmesa",))
    assert gl.choose_backend() == "osmesa"
    assert tried == ["egl", "osmesa"]
    assert [p.read_text() for p in cache.iterdir()] == ["osmesa"]
    tried.clear()
    assert gl.choose_backend() == "osmesa"
    assert tried == []


def test_the_real_trials_remember_the_backend_they_find(monkeypatch, cache):
    monkeypatch.setenv("MUJOCO_GL", "")
    found = gl.choose_backend()
    assert found in gl.BACKENDS
    assert (cache / gl.machine_key()).read_text() == found
    tried = trials(monkeypatch, works=())
    assert gl.choose_backend() == found
    assert tried == []


def test_a_failure_is_not_remembered(monkeypatch, cache):
    monkeypatch.setenv("MUJOCO_GL", "")
    tried = trials(monkeypatch, works=())
    with pytest.raises(PreviewError, match="no OpenGL back-end works"):
        gl.choose_backend()
    assert not cache.exists() or not any(cache.iterdir())
    monkeypatch.setattr(gl, "backend_problem", lambda b: tried.append(b))  # works now
    assert gl.choose_backend() == "egl"
    assert tried == ["egl", "osmesa", "egl"]


def test_a_named_backend_neither_tries_nor_reads_nor_writes_the_cache(monkeypatch, cache):
    monkeypatch.setenv("MUJOCO_GL", "")
    trials(monkeypatch, works=("osmesa",))
    gl.choose_backend()  # osmesa remembered
    monkeypatch.setenv("MUJOCO_GL", "egl")
    assert gl.choose_backend() == "egl"
    assert [p.read_text() for p in cache.iterdir()] == ["osmesa"]


def test_what_the_cache_holds_is_used_only_if_it_names_a_backend(monkeypatch, cache):
    monkeypatch.setenv("MUJOCO_GL", "")
    cache.mkdir(parents=True)
    (cache / gl.machine_key()).write_text("glfw")  # not one the trials choose among
    tried = trials(monkeypatch, works=("egl",))
    assert gl.choose_backend() == "egl"
    assert tried == ["egl"]
    assert (cache / gl.machine_key()).read_text() == "egl"


@pytest.mark.parametrize(
    "variable",
    ["MESA_LOADER_DRIVER_OVERRIDE", "EGL_PLATFORM", "LIBGL_ALWAYS_SOFTWARE", "LD_LIBRARY_PATH"],
)
def test_the_choice_is_tried_again_when_the_environment_steers_gl_otherwise(
    monkeypatch, cache, variable
):
    monkeypatch.setenv("MUJOCO_GL", "")
    monkeypatch.delenv(variable, raising=False)
    tried = trials(monkeypatch, works=("egl", "osmesa"))
    gl.choose_backend()
    monkeypatch.setenv(variable, "something else")
    gl.choose_backend()
    assert tried == ["egl", "egl"]


def test_the_choice_is_kept_whatever_mujoco_gl_and_pyopengl_platform_are_set_to_after(
    monkeypatch, cache
):
    """Rendering sets both once the choice is made: forgetting a failed back-end needs the key
    the choice was remembered under."""
    key = gl.machine_key()
    monkeypatch.setenv("MUJOCO_GL", "osmesa")
    monkeypatch.setenv("PYOPENGL_PLATFORM", "osmesa")
    assert gl.machine_key() == key


def test_the_choice_is_tried_again_when_a_library_is_installed(monkeypatch, cache, tmp_path):
    libraries = tmp_path / "ld.so.cache"  # ldconfig rewrites it on every install or removal
    libraries.write_bytes(b"libEGL.so.1")
    devices = tmp_path / "dri"
    devices.mkdir()
    monkeypatch.setattr(gl, "SYSTEM_PATHS", (str(libraries), str(devices)))
    monkeypatch.setenv("MUJOCO_GL", "")
    tried = trials(monkeypatch, works=("egl", "osmesa"))
    gl.choose_backend()
    gl.choose_backend()
    libraries.write_bytes(b"libEGL.so.1 libOSMesa.so.8")
    gl.choose_backend()
    (devices / "renderD128").touch()  # a GPU appeared
    gl.choose_backend()
    assert tried == ["egl", "egl", "egl"]


def test_the_choice_is_tried_again_for_another_python(monkeypatch, cache):
    monkeypatch.setenv("MUJOCO_GL", "")
    tried = trials(monkeypatch, works=("egl",))
    gl.choose_backend()
    monkeypatch.setattr("sys.executable", "/elsewhere/venv/bin/python")
    gl.choose_backend()
    assert tried == ["egl", "egl"]


def test_a_remembered_backend_that_fails_to_render_is_forgotten(monkeypatch, cache):
    monkeypatch.setenv("MUJOCO_GL", "")
    trials(monkeypatch, works=("egl",))
    gl.choose_backend()
    assert (cache / gl.machine_key()).exists()

    class Broken:
        def __init__(self, width, height):
            raise RuntimeError("eglInitialize failed")

    monkeypatch.setattr(gl, "context_class", lambda backend: Broken)
    model = mujoco.MjModel.from_xml_string("<mujoco><worldbody/></mujoco>")
    with pytest.raises(PreviewError, match="cannot create an offscreen egl context: eglInit"):
        in_a_new_thread(FrameRenderer, model, 16, 16, "egl")
    assert not (cache / gl.machine_key()).exists()
    assert check_cache.recall(gl.REMEMBERED, gl.machine_key()) is None


class FakeContext:
    """A GL context that only records what is done with it."""

    made: list[FakeContext] = []

    def __init__(self, width, height):
        self.size, self.current, self.freed = (width, height), 0, False
        FakeContext.made.append(self)

    def make_current(self):
        self.current += 1

    def free(self):
        self.freed = True


def test_a_context_given_back_is_taken_again_by_its_thread_for_frames_it_fits(monkeypatch):
    monkeypatch.setattr(gl, "context_class", lambda backend: FakeContext)
    monkeypatch.setattr(FakeContext, "made", [])

    def renders():
        first = gl.take_context("egl", 320, 240)
        gl.give_back(first)
        smaller = gl.take_context("egl", 160, 120)  # the kept one fits
        assert smaller is first and first.context.current == 2
        larger = gl.take_context("egl", 640, 480)  # none kept fits: a new one
        other_backend = gl.take_context("osmesa", 16, 16)
        assert len({id(c) for c in (first, larger, other_backend)}) == 3
        for offscreen in (larger, other_backend, smaller):
            gl.give_back(offscreen)
        return first

    first = in_a_new_thread(renders)
    assert len(FakeContext.made) == 3
    # two are kept: the oldest given back beyond them is freed
    assert [c.freed for c in FakeContext.made] == [False, True, False]
    # another thread has none of them
    assert in_a_new_thread(gl.take_context, "egl", 320, 240).context is not first.context
