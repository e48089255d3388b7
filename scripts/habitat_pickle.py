"""Reads checkpoints that habitat_baselines and VLN-CE write with torch.save
(a dict of tensors plus a pickled habitat/yacs Config) without habitat or
yacs installed and without running anything the file names.

Unpickling calls whatever globals a pickle names, so a hostile file can run
any code through a plain torch.load. Here every global is checked against a
short allow-list: tensor and storage rebuilders, OrderedDict, set, a few
numpy value constructors, and the config classes of habitat and yacs, which
are replaced by ConfigNode (a dict). Anything else (os.system,
subprocess.Popen, builtins.eval, a policy class, ...) stops the load with
ForbiddenGlobal naming it.

torch.load (1.13) always unpickles with the `pickle` module's Unpickler and
load(), whatever pickle_module it is given, so both are swapped for the
restricted ones while load_checkpoint() runs (zip and legacy formats alike).

Used by convert_vlnce_checkpoint.py, which runs as `python3 scripts/<name>.py`
and so finds this module beside it.
"""
import contextlib
import inspect
import pickle

import torch

# (module, name) pairs a checkpoint of tensors may name
_TENSOR_GLOBALS = {
    ("collections", "OrderedDict"),
    ("builtins", "set"),
    ("builtins", "frozenset"),
    ("__builtin__", "set"),  # protocol 2 spells builtins the Python 2 way
    ("__builtin__", "frozenset"),
    ("torch._utils", "_rebuild_tensor"),
    ("torch._utils", "_rebuild_tensor_v2"),
    ("torch._utils", "_rebuild_parameter"),
    ("torch._utils", "_rebuild_parameter_with_state"),
    ("torch._tensor", "_rebuild_from_type_v2"),
    ("torch", "Tensor"),
    ("torch.nn.parameter", "Parameter"),
    ("torch", "Size"),
    ("numpy", "dtype"),
    ("numpy", "ndarray"),
    ("numpy.core.multiarray", "scalar"),
    ("numpy.core.multiarray", "_reconstruct"),
}

# packages whose Config / CfgNode classes become ConfigNode
_CONFIG_PACKAGES = ("habitat", "habitat_baselines", "habitat_extensions",
                    "vlnce_baselines", "yacs")
_CONFIG_CLASSES = ("Config", "CfgNode")


class ForbiddenGlobal(pickle.UnpicklingError):
    """The pickle names a global that is not on the allow-list."""

    def __init__(self, module, name):
        super().__init__(f"{module}.{name}")
        self.module = module
        self.name = name


class CheckpointError(Exception):
    """A checkpoint that cannot be read; the message names the file."""


class ConfigNode(dict):
    """Stands in for habitat's Config and yacs' CfgNode, dict subclasses
    whose instance attributes (immutability flags, deprecated and renamed
    keys) only matter to yacs; they are dropped."""

    def __setstate__(self, state):
        del state


class RestrictedUnpickler(pickle.Unpickler):
    """pickle.Unpickler that resolves only allow-listed globals."""

    def find_class(self, module, name):
        if (module, name) in _TENSOR_GLOBALS:
            return super().find_class(module, name)
        if module == "torch" and name.endswith("Storage"):
            return super().find_class(module, name)
        if (module.split(".")[0] in _CONFIG_PACKAGES and
                name in _CONFIG_CLASSES):
            return ConfigNode
        raise ForbiddenGlobal(module, name)


def _restricted_load(file, **kwargs):
    return RestrictedUnpickler(file, **kwargs).load()


@contextlib.contextmanager
def _restricted_pickle_module():
    saved = pickle.Unpickler, pickle.load
    pickle.Unpickler, pickle.load = RestrictedUnpickler, _restricted_load
    try:
        yield
    finally:
        pickle.Unpickler, pickle.load = saved


def load_checkpoint(path):
    """torch.load(path) on the CPU through RestrictedUnpickler. Raises
    CheckpointError naming `path` when the file is missing, truncated, not a
    torch file, or names a global off the allow-list."""
    kwargs = {"map_location": "cpu"}
    if "weights_only" in inspect.signature(torch.load).parameters:
        kwargs["weights_only"] = False  # torch's own allow-list has no Config
    try:
        with _restricted_pickle_module():
            return torch.load(path, **kwargs)
    except ForbiddenGlobal as error:
        raise CheckpointError(
            f"{path}: refused: its pickle calls {error.module}.{error.name}, "
            "which is neither a tensor, a container nor a habitat/yacs "
            "config (nothing was run)") from None
    except FileNotFoundError:
        raise CheckpointError(f"{path}: no such file") from None
    except Exception as error:  # torch raises RuntimeError, EOFError, ...
        raise CheckpointError(
            f"{path}: not a readable torch checkpoint (truncated or "
            f"corrupt?): {type(error).__name__}: {error}") from None


def to_plain(value):
    """ConfigNode trees (and any dict) as plain dicts, tuples as lists."""
    if isinstance(value, dict):
        return {key: to_plain(item) for key, item in value.items()}
    if isinstance(value, (list, tuple)):
        return [to_plain(item) for item in value]
    return value
