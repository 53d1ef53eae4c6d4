import penumbra


def test_version_and_docs():
    assert penumbra.__version__.count(".") == 2
    assert penumbra.__doc__
    for name in dir(penumbra):
        obj = getattr(penumbra, name)
        if not name.startswith("_") and callable(obj):
            assert obj.__doc__, name


def test_devices(ctx):
    devs = penumbra.list_devices()
    assert devs and devs[0].index == 0
    info = ctx.info
    assert info.name and info.platform and info.version
    assert info.global_mem_bytes > 0 and info.max_work_group_size > 0
    assert (info.fp64, info.int64_atomics) == (devs[0].fp64, devs[0].int64_atomics)
    assert info.global_mem_bytes == devs[0].global_mem_bytes
    assert "DeviceInfo" in repr(info) and info.name in repr(ctx)
    assert penumbra.Context(0).info.name == devs[0].name
    assert penumbra.Context("0").info.name == devs[0].name


def test_stage_times(ctx, env):
    ctx.reset_timings()
    penumbra.cube_map_energy(ctx, env, 16)
    ctx.finish()
    t = ctx.stage_times_ms()
    # Only the resampling's stages ran (kernels/environment/envmap.cl), each taking some time.
    assert "env/resample" in t and all(k.startswith("env/resample") for k in t), t
    assert all(v > 0 for v in t.values()), t
    ctx.reset_timings()
    assert ctx.stage_times_ms() == {}
