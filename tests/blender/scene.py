# The test scene of the Blender add-on, built in Blender from its factory settings and
# saved to the .blend named after "--": a glass ball (ior 1.5) and a pool of water
# (an open, wavy surface of ior 1.33) above a plain diffuse floor, one point light of
# radius 0 (bbc's lights are points), a camera looking down at 40 degrees; Cycles with a
# black world, few samples, no denoising, 160x120 pixels.
#   blender -b --factory-startup --python tests/blender/scene.py -- OUT.blend
import math
import sys

import bpy

out = sys.argv[sys.argv.index("--") + 1]
bpy.ops.wm.read_factory_settings(use_empty=True)
scene = bpy.context.scene


def principled(name, color, roughness, transmission=0.0, ior=1.5):
    m = bpy.data.materials.new(name)
    m.use_nodes = True
    b = m.node_tree.nodes["Principled BSDF"]
    inputs = b.inputs
    inputs["Base Color"].default_value = color
    inputs["Roughness"].default_value = roughness
    inputs["Metallic"].default_value = 0.0
    # No specular layer on the floor: bbc's diffuse material is Lambert's alone. (4.x
    # names the socket "Specular IOR Level" and "Transmission Weight".)
    for n in ("Specular", "Specular IOR Level"):
        if n in inputs:
            inputs[n].default_value = 0.5 if transmission else 0.0
    for n in ("Transmission", "Transmission Weight"):
        if n in inputs:
            inputs[n].default_value = transmission
    inputs["IOR"].default_value = ior
    return m


floor_mat = principled("Floor", (0.8, 0.8, 0.8, 1.0), 1.0)
glass = principled("Glass", (1, 1, 1, 1), 0.0, transmission=1.0, ior=1.5)
water = principled("Water", (1, 1, 1, 1), 0.0, transmission=1.0, ior=1.33)

bpy.ops.mesh.primitive_plane_add(size=6.0, location=(0, 0, 0))
floor = bpy.context.object
floor.name = "Floor"
floor.data.materials.append(floor_mat)

bpy.ops.mesh.primitive_uv_sphere_add(segments=12, ring_count=6, radius=0.35,
                                     location=(-0.7, 0.2, 0.75))
ball = bpy.context.object
ball.name = "Ball"
bpy.ops.object.shade_smooth()
ball.data.materials.append(glass)

# The pool: a 1.2 x 1.2 water surface 0.2 above the floor, its normals up (bbc: water
# below, air above), with two gentle waves.
bpy.ops.mesh.primitive_grid_add(x_subdivisions=10, y_subdivisions=10, size=1.2,
                                location=(0.75, 0.1, 0.2))
pool = bpy.context.object
pool.name = "Pool"
for v in pool.data.vertices:
    v.co.z = 0.03 * math.sin(5.0 * v.co.x + 1.0) * math.cos(4.0 * v.co.y)
bpy.ops.object.shade_smooth()
pool.data.materials.append(water)

light_data = bpy.data.lights.new("Lamp", "POINT")
light_data.energy = 300.0           # W: bbc reads 300 / (4 pi) W/sr from the export
light_data.shadow_soft_size = 0.0   # a point, as bbc's
light = bpy.data.objects.new("Lamp", light_data)
light.location = (0.2, 0.6, 3.0)
scene.collection.objects.link(light)

cam_data = bpy.data.cameras.new("View")
cam_data.lens = 35.0
cam = bpy.data.objects.new("View", cam_data)
cam.location = (0.0, -3.2, 2.9)
cam.rotation_euler = (math.radians(48.0), 0.0, 0.0)
scene.collection.objects.link(cam)
scene.camera = cam

world = bpy.data.worlds.new("Black")
world.color = (0, 0, 0)
world.use_nodes = False
scene.world = world

scene.render.engine = "CYCLES"
scene.cycles.device = "CPU"
scene.cycles.samples = 16
scene.cycles.use_adaptive_sampling = False
scene.cycles.use_denoising = False
scene.cycles.seed = 1
scene.render.resolution_x = 160
scene.render.resolution_y = 120
scene.render.resolution_percentage = 100
scene.render.threads_mode = "FIXED"
scene.render.threads = 2
scene.frame_start = 1
scene.frame_end = 1
bpy.ops.wm.save_as_mainfile(filepath=out)
