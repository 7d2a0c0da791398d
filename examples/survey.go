// The README's first example: a scout flies ahead; the camera drone follows
// once the scout has signalled that it reached the site.
package Survey

var (
	Scout  Quadcopter
	Camera Quadcopter
)

func SEQ_Mission() {
	PAR_Up()
	PAR_Work()
	PAR_Down()
}

func PAR_Up() {
	SEQ_ScoutUp()
	SEQ_CameraUp()
}

func SEQ_ScoutUp() {
	Scout.Arm()
	Scout.Takeoff(5)
}

func SEQ_CameraUp() {
	Camera.Arm()
	Camera.Takeoff(3)
}

// The camera drone may only follow once the scout has reached the site.
func PAR_Work() {
	SEQ_Scout()
	SEQ_Photo()
}

func SEQ_Scout() {
	Scout.FlyByX(10)
	Signal("scouted")
	Scout.Hover(5)
}

func SEQ_Photo() {
	Camera.TurnOnCamera()
	Await("scouted")
	Camera.FlyByX(10)
	Camera.TakePhoto()
}

func PAR_Down() {
	Scout.Land()
	Camera.Land()
}
