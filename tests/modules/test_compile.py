"""``network.compile``: after warm-up the loop's calls run compiled, without recompiling.

The losses call the encoder with its parameters and with its target copies (plain tensors, via
functional calls); acting uses batch 1, the update B, DrQ's copies 2B. Compiled for static
shapes, ``conv_trunk`` was re-specialised for each combination until dynamo's recompile limit
and then ran eager.
"""
import shutil

import pytest
import torch
from torch.func import functional_call

from dcs_torchrl.modules import PixelEncoder


@pytest.mark.skipif(shutil.which("c++") is None and shutil.which("g++") is None, reason="inductor needs a C++ compiler")
def test_compiled_encoder_does_not_recompile_for_new_batch_sizes_or_target_weights():
    torch.compiler.reset()
    torch.manual_seed(0)
    eager = PixelEncoder(9, image_size=32)
    compiled = PixelEncoder(9, image_size=32, compile=True)
    compiled.load_state_dict(eager.state_dict())
    targets = {name: p.detach().clone() for name, p in compiled.named_parameters()}  # plain tensors

    def both(pixels):
        torch.testing.assert_close(compiled(pixels), eager(pixels), atol=1e-5, rtol=1e-4)
        torch.testing.assert_close(functional_call(compiled, targets, (pixels,)), eager(pixels), atol=1e-5, rtol=1e-4)

    shapes = (1, 16, 32)  # the loop's pattern, scaled down: acting 1, update B, DrQ's copies 2B
    for batch in shapes:  # warm-up: the graphs of each shape class and weight type
        both(torch.randint(0, 256, (batch, 9, 32, 32), dtype=torch.uint8))
    with torch._dynamo.config.patch(error_on_recompile=True):  # steady state: no recompiles at all
        for _ in range(2):
            for batch in shapes:
                both(torch.randint(0, 256, (batch, 9, 32, 32), dtype=torch.uint8))
