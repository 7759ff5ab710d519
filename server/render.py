"""A top-down picture of the world: rooms, walls, furniture (a drawer or door where it is, open or
closed), the semantic map, objects and robot.

Rendered headless with matplotlib's Agg canvas (no pyplot, no display, no global state), from
the scene and the ground-truth state, so it shows where things really are.
"""

from __future__ import annotations

import io

from robocog.server.world.world import World


def render_top_down(world: World, *, width_px: int = 1100, dpi: int = 100) -> bytes:
    """PNG bytes of a labelled top-down view of `world`."""
    from matplotlib.backends.backend_agg import FigureCanvasAgg
    from matplotlib.figure import Figure
    from matplotlib.patches import Rectangle

    scene, state = world.scene, world.state()
    xs = [v for r in scene.rooms for v in r.x] + [loc.x for loc in scene.locations]
    ys = [v for r in scene.rooms for v in r.y] + [loc.y for loc in scene.locations]
    x0, x1, y0, y1 = min(xs) - 0.5, max(xs) + 0.5, min(ys) - 0.5, max(ys) + 0.5
    aspect = (y1 - y0) / (x1 - x0)
    fig = Figure(figsize=(width_px / dpi, width_px / dpi * aspect), dpi=dpi)
    FigureCanvasAgg(fig)
    ax = fig.add_axes((0.02, 0.02, 0.96, 0.96))
    ax.set_xlim(x0, x1)
    ax.set_ylim(y0, y1)
    ax.set_aspect("equal")
    ax.axis("off")
    for room in scene.rooms:
        ax.add_patch(
            Rectangle((room.x[0], room.y[0]), room.x[1] - room.x[0], room.y[1] - room.y[0], color=room.color[:3])
        )
        ax.text(room.x[0] + 0.15, room.y[1] - 0.3, room.name, fontsize=11, color="0.35", style="italic")
    for wall in scene.walls:
        ax.plot([wall.start[0], wall.end[0]], [wall.start[1], wall.end[1]], color="0.3", lw=3, solid_capstyle="butt")
    for item in scene.furniture:
        for part in item.parts:
            (cx, cy, _), (sx, sy, _) = part.center, part.size
            ax.add_patch(Rectangle((cx - sx / 2, cy - sy / 2), sx, sy, color=part.color[:3], alpha=0.6))
    for f in state.furniture:  # furniture that opens: its carcass, its drawer or door where physics has it
        box = scene.container(f.name)
        (cx, cy, _), (sx, sy, _) = box.center, box.size
        ax.add_patch(Rectangle((cx - sx / 2, cy - sy / 2), sx, sy, color=box.color[:3], alpha=0.6, ec="0.3"))
        (mx0, my0, _), (mx1, my1, _) = world.drawer_or_door_aabb(f.name)
        ax.add_patch(Rectangle((mx0, my0), mx1 - mx0, my1 - my0, color="0.25", alpha=0.5))
        ax.annotate(f"{f.name} ({f.state})", (cx, cy), xytext=(-20, 0), textcoords="offset points", fontsize=7)
    for pos in scene.place_positions:
        (cx, cy), (sx, sy) = pos.center, pos.size
        ax.add_patch(Rectangle((cx - sx / 2, cy - sy / 2), sx, sy, fill=False, ls="--", lw=0.8, ec="0.45"))
    points = world.map.points
    for a, b in scene.edges:
        ax.plot([points[a][0], points[b][0]], [points[a][1], points[b][1]], color="tab:green", lw=1.2, alpha=0.7)
    for name, (x, y) in points.items():
        ax.plot(x, y, "o", color="tab:green", ms=7)
        ax.annotate(name, (x, y), xytext=(6, -12), textcoords="offset points", fontsize=8, color="darkgreen")
    colors = {name: world.object_spec(name).color[:3] for name in world.object_names}
    stacked: dict[tuple[float, float], int] = {}  # objects on layers above each other share x, y
    for p in sorted(state.objects, key=lambda p: -p.xyz[2]):
        x, y, _ = p.xyz
        slot = stacked.get((round(x, 1), round(y, 1)), 0)
        stacked[(round(x, 1), round(y, 1))] = slot + 1
        ax.plot(x, y, "s", color=colors.get(p.object, (0.5, 0.5, 0.5)), ms=9, mec="black")
        label = p.object + (f" ({p.position})" if p.position else "")
        ax.annotate(label, (x, y), xytext=(6, 5 - 11 * slot), textcoords="offset points", fontsize=8, weight="bold")
    rx, ry, _ = state.robot.xyz
    sx, sy, _ = world.robot_spec.base_size
    ax.add_patch(Rectangle((rx - sx / 2, ry - sy / 2), sx, sy, color="tab:blue", alpha=0.85))
    held = f" holding {state.robot.holding}" if state.robot.holding else ""
    ax.annotate(
        f"robot{held}",
        (rx, ry),
        xytext=(0, 14),
        textcoords="offset points",
        fontsize=9,
        color="tab:blue",
        ha="center",
        weight="bold",
    )
    buf = io.BytesIO()
    fig.savefig(buf, format="png", dpi=dpi)
    return buf.getvalue()
