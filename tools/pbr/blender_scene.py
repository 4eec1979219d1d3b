"""Builds the rig as 3D geometry in Blender and path-traces its frames with Cycles.

Run inside Blender (`blender -b --python-exit-code 1 -P blender_scene.py -- SHOT.json`); the
driver (`pbr.py`) writes SHOT.json. Everything that moves is given as keyed world matrices at
Blender frame times the driver computed: Blender frame k + u stands for the instant
`t0_k + u * frame_interval_s` of output frame k, where t0_k is the start of row 0's exposure,
so that Cycles' shutter window [k, k + shutter] is frame k's exposure and readout.

Output: `raw_NNNNNN.png`, 16-bit RGB, scene-linear (view transform "Raw", no dither): the light
the sensor collects, with 1.0 its saturation. Sensor noise, tone curve and codec are the
driver's (`sensor.py`), none of them Blender's.

World frame: the project's (metres; disc plane z = 0, x right and y down in the image of an
untilted camera, the camera on the -z side looking along +z).
"""

import json
import math
import os
import sys

import bpy
from mathutils import Matrix


def shot_path():
    argv = sys.argv
    if "--" not in argv or argv.index("--") + 1 >= len(argv):
        raise SystemExit("blender_scene.py: usage: blender -b -P blender_scene.py -- SHOT.json")
    return argv[argv.index("--") + 1]


def clear_scene():
    for o in list(bpy.data.objects):
        bpy.data.objects.remove(o, do_unlink=True)
    for coll in (bpy.data.meshes, bpy.data.materials, bpy.data.lights, bpy.data.cameras,
                 bpy.data.images, bpy.data.node_groups):
        for item in list(coll):
            coll.remove(item)


def matrix(rows):
    return Matrix([rows[0:4], rows[4:8], rows[8:12], rows[12:16]])


def new_object(name, data, parent=None):
    o = bpy.data.objects.new(name, data)
    bpy.context.scene.collection.objects.link(o)
    if parent is not None:
        o.parent = parent
    return o


def mesh_object(name, verts, faces, uvs=None, parent=None):
    """A mesh from vertices (m, in the parent's frame) and faces; `uvs` per face corner."""
    me = bpy.data.meshes.new(name)
    me.from_pydata(verts, [], faces)
    if uvs is not None:
        layer = me.uv_layers.new(name="UVMap")
        for loop in me.loops:
            layer.data[loop.index].uv = uvs[loop.vertex_index]
    me.update()
    return new_object(name, me, parent)


def quad(name, corners, z, parent=None, uv=True):
    """A quad facing the camera (-z) through four (x, y) corners: TL, TR, BR, BL as seen."""
    verts = [(x, y, z) for x, y in corners]
    # Wound TL, BL, BR, TR: the normal (right-handed) points to -z, towards the camera.
    faces = [(0, 3, 2, 1)]
    uvs = [(0.0, 1.0), (1.0, 1.0), (1.0, 0.0), (0.0, 0.0)] if uv else None
    return mesh_object(name, verts, faces, uvs, parent)


def disc_mesh(name, radius, z_front, thickness, segments, parent=None):
    """A cylinder whose front face (z = z_front) faces the camera; UVs are planar (x, y) in m."""
    verts, faces = [], []
    for k in range(segments):
        a = 2.0 * math.pi * k / segments
        verts.append((radius * math.cos(a), radius * math.sin(a), z_front))
    for k in range(segments):
        a = 2.0 * math.pi * k / segments
        verts.append((radius * math.cos(a), radius * math.sin(a), z_front + thickness))
    # Front face wound so its normal points to -z (towards the camera).
    faces.append(tuple(range(segments - 1, -1, -1)))
    faces.append(tuple(range(segments, 2 * segments)))
    for k in range(segments):
        n = (k + 1) % segments
        faces.append((k, n, segments + n, segments + k))
    me = bpy.data.meshes.new(name)
    me.from_pydata(verts, [], faces)
    me.update()
    return new_object(name, me, parent)


def node(tree, kind, **props):
    n = tree.nodes.new(kind)
    for k, v in props.items():
        setattr(n, k, v)
    return n


def principled(name):
    m = bpy.data.materials.new(name)
    m.use_nodes = True
    tree = m.node_tree
    bsdf = tree.nodes["Principled BSDF"]
    return m, tree, bsdf


def link(tree, a, out, b, inp):
    tree.links.new(a.outputs[out], b.inputs[inp])


def texture(t, kind, vector, scale, **props):
    """A procedural texture on `vector` (a node and its output), `scale` cycles per metre."""
    tex = node(t, kind, **props)
    tex.inputs["Scale"].default_value = scale
    link(t, vector[0], vector[1], tex, "Vector")
    return tex


def noise(t, vector, scale, detail=2.0, distortion=0.0):
    tex = texture(t, "ShaderNodeTexNoise", vector, scale)
    tex.inputs["Detail"].default_value = detail
    tex.inputs["Distortion"].default_value = distortion
    return tex


def remap(t, source, out, lo, hi):
    """A texture's 0…1 output mapped onto lo…hi (a tint's or a roughness' range)."""
    r = node(t, "ShaderNodeMapRange")
    r.inputs["To Min"].default_value = lo
    r.inputs["To Max"].default_value = hi
    link(t, source, out, r, "Value")
    return r


def tint(t, colour, *factors):
    """`colour` multiplied by each (node, output) factor in turn; returns the last node."""
    current = None
    for source, out in factors:
        mix = node(t, "ShaderNodeMixRGB", blend_type="MULTIPLY")
        mix.inputs["Fac"].default_value = 1.0
        if current is None:
            mix.inputs["Color1"].default_value = (*colour, 1.0)
        else:
            link(t, current, "Color", mix, "Color1")
        link(t, source, out, mix, "Color2")
        current = mix
    return current


def bump(t, source, out, bsdf, strength, distance_m=None):
    b = node(t, "ShaderNodeBump")
    b.inputs["Strength"].default_value = strength
    if distance_m is not None:
        b.inputs["Distance"].default_value = distance_m
    link(t, source, out, b, "Height")
    link(t, b, "Normal", bsdf, "Normal")


def disc_material(spec):
    """Orange PLA: print lines as a relief (bump from a wave texture across the disc's object
    coordinates), the lines' slight colour banding, and a low-frequency mottling."""
    m, t, bsdf = principled("disc")
    coord = node(t, "ShaderNodeTexCoord")
    mapping = node(t, "ShaderNodeMapping")
    mapping.inputs["Rotation"].default_value = (0.0, 0.0, math.radians(spec["line_angle_deg"]))
    link(t, coord, "Object", mapping, "Vector")
    # A wave of period 1/scale in its input's units (metres): spacing 0.4 mm → scale 2500.
    lines = texture(t, "ShaderNodeTexWave", (mapping, "Vector"), 1.0 / spec["line_spacing_m"],
                    wave_type="BANDS", bands_direction="X", wave_profile="SIN")
    lines.inputs["Distortion"].default_value = 0.5
    mottle = noise(t, (coord, "Object"), 40.0)
    colour = tint(t, spec["colour"],
                  (remap(t, mottle, "Fac", 1.0 - spec["mottle"], 1.0), "Result"),
                  (remap(t, lines, "Fac", 1.0 - spec["line_banding"], 1.0), "Result"))
    link(t, colour, "Color", bsdf, "Base Color")
    bump(t, lines, "Fac", bsdf, spec["bump_strength"], spec["bump_distance_m"])
    bsdf.inputs["Roughness"].default_value = spec["roughness"]
    bsdf.inputs["Specular"].default_value = spec["specular"]
    return m


def paper_material(name, image_path, spec):
    """Printed paper: the marker image (nearest-texel lookup, so cell edges stay straight),
    toner glossier than paper, a paper-fibre bump; an optional clear laminate (glare)."""
    m, t, bsdf = principled(name)
    img = bpy.data.images.load(image_path)
    img.colorspace_settings.name = "Non-Color"
    tex = node(t, "ShaderNodeTexImage", interpolation="Closest", extension="EXTEND")
    tex.image = img
    uv = node(t, "ShaderNodeUVMap")
    link(t, uv, "UV", tex, "Vector")
    # The image holds reflectance directly (0 = ink, 1 = paper): scale to albedos.
    albedo = remap(t, tex, "Color", spec["ink_albedo"], spec["paper_albedo"])
    link(t, albedo, "Result", bsdf, "Base Color")
    rough = remap(t, tex, "Color", spec["ink_roughness"], spec["paper_roughness"])
    link(t, rough, "Result", bsdf, "Roughness")
    coord = node(t, "ShaderNodeTexCoord")
    bump(t, noise(t, (coord, "Object"), 3000.0), "Fac", bsdf, spec["fibre_bump"])
    bsdf.inputs["Specular"].default_value = spec["specular"]
    if spec.get("laminate", 0.0) > 0.0:
        bsdf.inputs["Clearcoat"].default_value = spec["laminate"]
        bsdf.inputs["Clearcoat Roughness"].default_value = spec.get("laminate_roughness", 0.05)
    return m


def tape_material(spec):
    m, t, bsdf = principled("tape")
    bsdf.inputs["Base Color"].default_value = (*spec["colour"], 1.0)
    bsdf.inputs["Roughness"].default_value = spec["roughness"]
    coord = node(t, "ShaderNodeTexCoord")
    bump(t, noise(t, (coord, "Object"), 400.0), "Fac", bsdf, 0.15)
    return m


def wood_material(spec):
    """A base plate's wood: grain stretched along x."""
    m, t, bsdf = principled("plate")
    coord = node(t, "ShaderNodeTexCoord")
    mapping = node(t, "ShaderNodeMapping")
    mapping.inputs["Scale"].default_value = (1.0, 12.0, 1.0)
    link(t, coord, "Object", mapping, "Vector")
    grain = noise(t, (mapping, "Vector"), 25.0, detail=3.0, distortion=2.0)
    colour = tint(t, spec["colour"], (remap(t, grain, "Fac", 0.7, 1.15), "Result"))
    link(t, colour, "Color", bsdf, "Base Color")
    bsdf.inputs["Roughness"].default_value = 0.6
    return m


def fabric_material(spec):
    """Woven fabric: warp and weft as crossed bands (a bump), in folds that shade it."""
    m, t, bsdf = principled("fabric")
    coord = node(t, "ShaderNodeTexCoord")
    threads = [texture(t, "ShaderNodeTexWave", (coord, "Object"), 1.0 / spec["thread_m"],
                       wave_type="BANDS", bands_direction=d) for d in ("X", "Y")]
    weave = node(t, "ShaderNodeMath", operation="MULTIPLY")
    link(t, threads[0], "Fac", weave, 0)
    link(t, threads[1], "Fac", weave, 1)
    folds = noise(t, (coord, "Object"), 6.0)
    colour = tint(t, spec["colour"], (remap(t, folds, "Fac", 0.6, 1.2), "Result"))
    link(t, colour, "Color", bsdf, "Base Color")
    bsdf.inputs["Roughness"].default_value = 0.95
    bsdf.inputs["Sheen"].default_value = 0.5
    bump(t, weave, "Value", bsdf, 0.4)
    return m


def plain_material(name, colour, roughness, metallic=0.0):
    m, _, bsdf = principled(name)
    bsdf.inputs["Base Color"].default_value = (*colour, 1.0)
    bsdf.inputs["Roughness"].default_value = roughness
    bsdf.inputs["Metallic"].default_value = metallic
    return m


def key_matrices(obj, keys):
    """Keys the object's local matrix at Blender frame times (linear interpolation between)."""
    obj.rotation_mode = "QUATERNION"
    for frame, rows in keys:
        obj.matrix_basis = matrix(rows)
        for path in ("location", "rotation_quaternion", "scale"):
            obj.keyframe_insert(data_path=path, frame=frame)
    linear_keys(obj)


def linear_keys(idblock):
    ad = idblock.animation_data
    if ad is None or ad.action is None:
        return
    for fc in ad.action.fcurves:
        for kp in fc.keyframe_points:
            kp.interpolation = "LINEAR"


def place(obj, rows):
    obj.rotation_mode = "QUATERNION"
    obj.matrix_basis = matrix(rows)


def build_paper(name, spec, parent):
    """The printed sheet: a quad (marker + margin) in the parent's frame, z slightly in front."""
    half = spec["paper_side_m"] / 2.0
    corners = [(-half, -half), (half, -half), (half, half), (-half, half)]
    obj = quad(name, corners, -spec["thickness_m"], parent)
    obj.data.materials.append(paper_material(name, spec["image"], spec["material"]))
    return obj


MOTION_STEPS = 3


def build(shot):
    global MOTION_STEPS
    MOTION_STEPS = min(7, max(1, int(shot.get("motion_steps", 3))))
    scene = bpy.context.scene
    r = scene.render
    r.engine = "CYCLES"
    cy = scene.cycles
    cy.device = "CPU"
    cy.samples = shot["samples"]
    cy.use_adaptive_sampling = False
    cy.use_denoising = False
    cy.seed = shot["seed"]
    cy.use_animated_seed = True
    cy.max_bounces = shot.get("max_bounces", 2)
    cy.diffuse_bounces = shot.get("diffuse_bounces", 1)
    cy.glossy_bounces = 1
    cy.transmission_bounces = 1
    cy.transparent_max_bounces = 4
    cy.volume_bounces = 0
    cy.caustics_reflective = False
    cy.caustics_refractive = False
    cy.pixel_filter_type = "BOX"
    cy.filter_width = 1.0
    cy.sample_clamp_indirect = 10.0
    r.threads_mode = "FIXED"
    r.threads = shot["threads"]
    r.resolution_x = shot["render_width"]
    r.resolution_y = shot["render_height"]
    r.resolution_percentage = 100
    r.pixel_aspect_x = r.pixel_aspect_y = 1.0
    r.use_persistent_data = True
    r.dither_intensity = 0.0
    r.image_settings.file_format = "PNG"
    r.image_settings.color_mode = "RGB"
    r.image_settings.color_depth = "16"
    r.image_settings.compression = 15
    scene.view_settings.view_transform = "Raw"
    scene.view_settings.look = "None"
    scene.view_settings.exposure = 0.0
    scene.view_settings.gamma = 1.0
    scene.sequencer_colorspace_settings.name = "Linear"
    r.fps = 30
    r.fps_base = 1.0
    shutter = shot["shutter_frames"]
    r.use_motion_blur = shutter > 0.0
    if shutter > 0.0:
        r.motion_blur_shutter = shutter
        cy.motion_blur_position = "START"
        if shot["rolling_duration"] is not None:
            cy.rolling_shutter_type = "TOP"
            cy.rolling_shutter_duration = shot["rolling_duration"]
        else:
            cy.rolling_shutter_type = "NONE"

    world = bpy.data.worlds.new("room") if not bpy.data.worlds else bpy.data.worlds[0]
    scene.world = world
    world.use_nodes = True
    world.node_tree.nodes["Background"].inputs["Color"].default_value = (*shot["room"]["colour"], 1)
    world.node_tree.nodes["Background"].inputs["Strength"].default_value = shot["room"]["strength"]

    # Camera: intrinsics on a 36 mm wide virtual sensor, pose keyed per frame.
    cam_spec = shot["camera"]
    cam_data = bpy.data.cameras.new("phone")
    cam_data.sensor_fit = "HORIZONTAL"
    cam_data.sensor_width = 36.0
    cam_data.lens = cam_spec["focal_px"] * 36.0 / shot["render_width"]
    cam_data.shift_x = cam_spec["shift"][0]
    cam_data.shift_y = cam_spec["shift"][1]
    cam_data.clip_start = 0.01
    cam_data.clip_end = 10.0
    dof = cam_spec["dof"]
    cam_data.dof.use_dof = dof["aperture_m"] > 0.0
    if cam_data.dof.use_dof:
        # Blender's aperture radius is lens / (2 f-stop), the lens in mm taken in scene mm.
        cam_data.dof.aperture_fstop = (cam_data.lens * 1e-3) / dof["aperture_m"]
        cam_data.dof.aperture_blades = dof["blades"]
        cam_data.dof.focus_distance = dof["focus_keys"][0][1]
        if len(dof["focus_keys"]) > 1:
            for frame, dist in dof["focus_keys"]:
                cam_data.dof.focus_distance = dist
                cam_data.dof.keyframe_insert("focus_distance", frame=frame)
            linear_keys(cam_data)
    cam = new_object("camera", cam_data)
    key_matrices(cam, cam_spec["keys"])
    cam.cycles.motion_steps = MOTION_STEPS
    scene.camera = cam

    # The wheel: its pose keyed; disc, hub and the marker sheet ride on it.
    wheel_spec = shot["wheel"]
    wheel = new_object("wheel", None)
    key_matrices(wheel, wheel_spec["keys"])
    wheel.cycles.motion_steps = MOTION_STEPS
    disc = disc_mesh("disc", wheel_spec["disc_radius_m"], 0.0, wheel_spec["thickness_m"], 256,
                     wheel)
    disc.data.materials.append(disc_material(wheel_spec["material"]))
    disc.cycles.motion_steps = MOTION_STEPS
    hub = disc_mesh("hub", wheel_spec["hub_radius_m"], -wheel_spec["hub_height_m"],
                    wheel_spec["hub_height_m"], 6, wheel)
    hub.data.materials.append(plain_material("steel", (0.55, 0.55, 0.57), 0.35, 0.9))

    m_spec = shot["marker"]
    holder = new_object("marker_holder", None, wheel)
    if m_spec["keys"]:
        key_matrices(holder, m_spec["keys"])
    else:
        place(holder, m_spec["pose"])
    holder.cycles.motion_steps = MOTION_STEPS
    paper = build_paper("marker_paper", m_spec, holder)
    paper.cycles.motion_steps = MOTION_STEPS
    tape = tape_material(shot["tape"]["material"])
    for i, strip in enumerate(shot["tape"]["strips"]):
        t = quad(f"tape{i}", strip, -m_spec["thickness_m"] - 0.00008, holder, uv=False)
        t.data.materials.append(tape)

    plate = shot["plate"]
    p = quad("plate", plate["corners"], plate["z_m"])
    p.data.materials.append(wood_material(plate["material"]))
    fab = shot["fabric"]
    f = quad("fabric", fab["corners"], fab["z_m"])
    f.data.materials.append(fabric_material(fab["material"]))

    for i, light in enumerate(shot["lights"]):
        data = bpy.data.lights.new(f"light{i}", "AREA")
        data.shape = "RECTANGLE"
        data.size, data.size_y = light["size_m"]
        data.energy = light["power_w"]
        data.color = light.get("colour", (1.0, 1.0, 1.0))
        lo = new_object(f"light{i}", data)
        place(lo, light["pose"])

    for extra in shot.get("extras", []):
        build_extra(extra)
    return scene


def build_extra(extra):
    """Objects of the novel effects: a second printed marker, an occluding cable, a shadow-
    casting card, each static or keyed."""
    kind = extra["kind"]
    if kind == "sheet":
        holder = new_object(extra["name"] + "_holder", None)
        place(holder, extra["pose"])
        build_paper(extra["name"], extra["sheet"], holder)
    elif kind in ("cable", "card"):
        if kind == "cable":
            me_obj = disc_mesh(extra["name"], extra["radius_m"], -extra["radius_m"],
                               2 * extra["radius_m"], 12)
            # A long thin cylinder: the short one stretched along its axis.
            me_obj.data.transform(Matrix.Diagonal((1.0, 1.0, extra["length_m"] /
                                                   (2 * extra["radius_m"]), 1.0)))
            me_obj.data.materials.append(plain_material("cable", tuple(extra["colour"]), 0.4))
        else:
            half_w, half_h = extra["size_m"][0] / 2, extra["size_m"][1] / 2
            me_obj = quad(extra["name"], [(-half_w, -half_h), (half_w, -half_h),
                                          (half_w, half_h), (-half_w, half_h)], 0.0, uv=False)
            me_obj.data.materials.append(plain_material("card", tuple(extra["colour"]), 0.8))
        me_obj.cycles.motion_steps = MOTION_STEPS
        if extra.get("keys"):
            key_matrices(me_obj, extra["keys"])
        else:
            place(me_obj, extra["pose"])
    elif kind == "light":
        data = bpy.data.lights.new(extra["name"], "AREA")
        data.shape = "DISK"
        data.size = extra["size_m"]
        data.energy = extra["power_w"]
        lo = new_object(extra["name"], data)
        place(lo, extra["pose"])
    else:
        raise SystemExit(f"blender_scene.py: unknown extra object kind {kind!r}")


def render(shot, scene):
    out = shot["out_dir"]
    frames = shot["frames"]
    scene.frame_start = 0
    scene.frame_end = frames - 1
    scene.frame_step = 1
    scene.render.filepath = os.path.join(out, "raw_######")
    scene.render.use_file_extension = True
    if shot.get("only_frames"):
        for k in shot["only_frames"]:
            scene.frame_set(k)
            scene.render.filepath = os.path.join(out, f"raw_{k:06d}")
            bpy.ops.render.render(write_still=True)
    else:
        bpy.ops.render.render(animation=True)


def main():
    with open(shot_path()) as f:
        shot = json.load(f)
    clear_scene()
    scene = build(shot)
    if shot.get("save_blend"):
        bpy.ops.wm.save_as_mainfile(filepath=shot["save_blend"])
    render(shot, scene)


main()
