"""``sphrom scenes``: list the built-in scenes with a one-line summary."""


def add_parser(sub):
    p = sub.add_parser("scenes", help="list the built-in scenes",
                       description="List the built-in scenes (validation/scenes/*.toml) with a one-line summary. "
                                   "Any command that takes SCENE also takes a path to a scene file.")
    p.add_argument("--paths", action="store_true", help="also print each scene's file path")
    p.set_defaults(handler=run)


def run(args):
    from ..scene import builtin_dir, builtin_names, load_scene

    names = builtin_names()
    width = max(len(n) for n in names)
    for name in names:
        scene = load_scene(name)
        print(f"{name:<{width}}  §{scene.section:<4} {scene.summary}")
        if args.paths:
            print(f"{'':<{width}}  {builtin_dir() / (name + '.toml')}")
    return 0
