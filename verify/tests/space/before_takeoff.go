// D1 flies before it took off, and takes off after it disarmed.
package BeforeTakeoff

var (
	D1 Quadcopter
	D2 Quadcopter
)

func PAR_Mission() {
	SEQ_One()
	SEQ_Two()
}

func SEQ_One() {
	D1.Arm()
	D1.FlyByX(3)
}

func SEQ_Two() {
	D2.Arm()
	D2.Disarm()
	D2.Takeoff(5)
	D2.Hover(-1)
}
