"""Render a preview of a baked .blend: every mesh shows its baked light x its base colour as emission, which a
Cycles render converges in a few samples. Usage: python scripts/render_preview.py BAKED.blend OUT.png [ATTRIBUTE]

The .blend is not saved: the preview materials exist only in this process.
"""
import sys

import bpy


def preview_material(source, attribute: str):
    """Emission = colour attribute x the source material's base colour."""
    material = bpy.data.materials.new(f"Preview {source.name if source else ''}")
    material.use_nodes = True
    nodes, links = material.node_tree.nodes, material.node_tree.links
    nodes.clear()
    light = nodes.new("ShaderNodeVertexColor")
    light.layer_name = attribute
    albedo = nodes.new("ShaderNodeMix")
    albedo.data_type, albedo.blend_type = "RGBA", "MULTIPLY"
    albedo.inputs["Factor"].default_value = 1.0
    base = (0.8, 0.8, 0.8, 1.0)
    if source is not None and source.node_tree and "Principled BSDF" in source.node_tree.nodes:
        bsdf = source.node_tree.nodes["Principled BSDF"]
        base = tuple(bsdf.inputs["Base Color"].default_value)
        emission = tuple(c * bsdf.inputs["Emission Strength"].default_value
                         for c in bsdf.inputs["Emission Color"].default_value[:3])
        if max(emission) > 0:  # emitters show their own radiance
            base = (0.0, 0.0, 0.0, 1.0)
    links.new(light.outputs["Color"], albedo.inputs["A"])
    albedo.inputs["B"].default_value = base
    shader = nodes.new("ShaderNodeEmission")
    if source is not None and max(base[:3]) == 0 and source.node_tree:
        bsdf = source.node_tree.nodes.get("Principled BSDF")
        shader.inputs["Color"].default_value = bsdf.inputs["Emission Color"].default_value
        shader.inputs["Strength"].default_value = bsdf.inputs["Emission Strength"].default_value
    else:
        links.new(albedo.outputs["Result"], shader.inputs["Color"])
    output = nodes.new("ShaderNodeOutputMaterial")
    links.new(shader.outputs["Emission"], output.inputs["Surface"])
    return material


def main(blend: str, png: str, attribute: str = "Radiosity") -> None:
    bpy.ops.wm.open_mainfile(filepath=blend)
    for obj in bpy.context.scene.objects:
        if obj.type == "MESH" and attribute in obj.data.color_attributes:
            sources = [slot.material for slot in obj.material_slots] or [None]
            for index, source in enumerate(sources):
                material = preview_material(source, attribute)
                if obj.material_slots:
                    obj.material_slots[index].link = "OBJECT"
                    obj.material_slots[index].material = material
                else:
                    obj.data.materials.append(material)
    scene = bpy.context.scene
    scene.render.engine = "CYCLES"
    scene.cycles.device = "CPU"
    scene.cycles.samples = 8
    scene.cycles.max_bounces = 0
    scene.render.filepath = png
    scene.render.image_settings.file_format = "PNG"
    bpy.ops.render.render(write_still=True)
    print(f"wrote {png}")


if __name__ == "__main__":
    main(*sys.argv[1:])
