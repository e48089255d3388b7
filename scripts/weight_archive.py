"""The tensor archive that vlnce-cpp reads as `model.rgb_weights` and
`model.depth_weights`: a TorchScript archive (a tree of empty modules
holding the tensors as buffers under their dotted names) that C++ opens
with torch::jit::load, without Python.

Shared by convert_torchvision_resnet50.py and convert_ddppo_depth.py, which
run as `python3 scripts/<name>.py` and so find this module beside them.
"""
import torch


def tensor_archive(tensors):
    """A scriptable module tree holding `tensors` (dotted names) as buffers."""

    class Node(torch.nn.Module):
        pass

    root = Node()
    for name, tensor in tensors.items():
        *path, leaf = name.split(".")
        node = root
        for part in path:
            if not hasattr(node, part):
                node.add_module(part, Node())
            node = getattr(node, part)
        node.register_buffer(leaf, tensor.detach().cpu().contiguous())
    return torch.jit.script(root)
