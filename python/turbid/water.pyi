# Type stubs of turbid.water (python/turbid/water.py).
from typing import Any, Dict, List, Literal, Mapping, NamedTuple, Optional, Sequence, Union

import numpy as np
import numpy.typing as npt

ArrayLike = Any  # numpy.ndarray, torch.Tensor (CPU), anything with __array__ / __dlpack__
Intrinsics = Union[ArrayLike, Sequence[float], None]

class WaterFit(NamedTuple):
    params: Dict[str, Any]
    diagnostics: Dict[str, Any]
    plot: npt.NDArray[np.float32]

def fit(image: Union[ArrayLike, Sequence[ArrayLike]],
        depth: Union[ArrayLike, Sequence[ArrayLike]],
        K: Union[Intrinsics, Sequence[Intrinsics]] = ...,
        depth_kind: Optional[Literal["z", "range"]] = ...,
        encoding: Optional[Literal["srgb", "linear"]] = ...,
        options: Optional[Mapping[str, Any]] = ...,
        channel_axis: int = ...) -> WaterFit: ...
